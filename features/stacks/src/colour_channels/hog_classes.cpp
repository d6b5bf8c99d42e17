// HOG class channels: the descriptors, the softmax regression, the rasters and the model file
// (hog_classes.hpp).
#include "smseg/stacks/hog_classes.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include <opencv2/objdetect.hpp>

#include "smseg/common/error.hpp"
#include "learned_files.hpp"

namespace smseg::stacks {

namespace {

constexpr int kModelVersion = 1;  // of the "smseg-hog-classes" file
constexpr int kBatch = 256;       // samples a step of Adam
constexpr double kProbabilitySteps = 255;  // a channel holds 255 p, rounded: a byte a pixel in the stack
constexpr double kAdamBeta1 = 0.9, kAdamBeta2 = 0.999, kAdamEpsilon = 1e-8;

cv::HOGDescriptor hog_of(cv::Size window) {
  return cv::HOGDescriptor(window, cv::Size(16, 16), cv::Size(8, 8), cv::Size(8, 8), 9);
}

constexpr const char* kWindowRule = "multiples of 16 (then half a window pads the image by whole cells)";

bool valid_window(cv::Size window) {
  return window.width >= 16 && window.height >= 16 && window.width % 16 == 0 && window.height % 16 == 0;
}

std::string size_text(cv::Size s) { return std::to_string(s.width) + "x" + std::to_string(s.height); }

/// Descriptor rows as z-scores (in place).
void standardise(cv::Mat& rows, const std::vector<double>& mean, const std::vector<double>& scale) {
  for (int r = 0; r < rows.rows; ++r) {
    float* d = rows.ptr<float>(r);
    for (int i = 0; i < rows.cols; ++i) d[i] = static_cast<float>((d[i] - mean[i]) * scale[i]);
  }
}

/// Softmax probabilities of one z-scored row into `p` (sized classes): the logits first, less their
/// largest so that exp cannot overflow.
void softmax(const float* z, const cv::Mat& w, const std::vector<double>& b, std::vector<double>& p) {
  double top = -HUGE_VAL;
  for (int c = 0; c < w.rows; ++c) {
    const double* wc = w.ptr<double>(c);
    double s = b[c];
    for (int i = 0; i < w.cols; ++i) s += wc[i] * z[i];
    p[c] = s;
    top = std::max(top, s);
  }
  double total = 0;
  for (double& v : p) total += (v = std::exp(v - top));
  for (double& v : p) v /= total;
}

/// Per-class sample weights: the negatives' subsampling undone, then 1 / sqrt(count) (the forest's
/// --balance sqrt), scaled to a mean of 1 over the samples.
std::vector<double> class_weights(const HogSamples& s, const std::vector<bool>& kept_whole, int negatives) {
  std::vector<double> count(s.classes.size(), 0.0), w(s.classes.size(), 0.0);
  for (int l : s.labels) count[l] += kept_whole[l] ? 1.0 : negatives;
  double total = 0;
  for (int l : s.labels) total += 1.0 / std::sqrt(count[l]) * (kept_whole[l] ? 1.0 : negatives);
  const double norm = static_cast<double>(s.labels.size()) / total;
  for (std::size_t c = 0; c < w.size(); ++c)
    if (count[c] > 0) w[c] = norm / std::sqrt(count[c]) * (kept_whole[c] ? 1.0 : negatives);
  return w;
}

/// Fisher-Yates with the generator's own draws: the same order on every platform.
std::vector<int> shuffled(int n, std::mt19937_64& rng) {
  std::vector<int> order(n);
  for (int i = 0; i < n; ++i) order[i] = i;
  for (int i = n - 1; i > 0; --i) std::swap(order[i], order[rng() % std::uint64_t(i + 1)]);
  return order;
}

/// Adam's moments of the weights and biases.
struct Adam {
  cv::Mat m, v;  // classes x (entries + 1), the bias last
  long step = 0;
};

void adam_step(const cv::Mat& grad, double rate, Adam& a, cv::Mat& w, std::vector<double>& b) {
  ++a.step;
  const double c1 = 1 - std::pow(kAdamBeta1, double(a.step)), c2 = 1 - std::pow(kAdamBeta2, double(a.step));
  for (int c = 0; c < grad.rows; ++c)
    for (int i = 0; i < grad.cols; ++i) {
      const double g = grad.at<double>(c, i);
      double& m = a.m.at<double>(c, i);
      double& v = a.v.at<double>(c, i);
      m = kAdamBeta1 * m + (1 - kAdamBeta1) * g;
      v = kAdamBeta2 * v + (1 - kAdamBeta2) * g * g;
      const double delta = rate * (m / c1) / (std::sqrt(v / c2) + kAdamEpsilon);
      (i < w.cols ? w.at<double>(c, i) : b[c]) -= delta;
    }
}

}  // namespace

std::vector<std::string> HogClassifier::feature_names() const {
  std::vector<std::string> names;
  for (const auto& c : channels) names.push_back(kHogClassPrefix + c);
  return names;
}

bool is_hog_class_feature(const std::string& name) { return name.rfind(kHogClassPrefix, 0) == 0; }

cv::Size hog_grid_size(cv::Size image) { return {image.width / kHogGridStep + 1, image.height / kHogGridStep + 1}; }

std::vector<int> class_positions(const std::vector<std::string>& classes, const std::vector<std::string>& names,
                                 const std::string& file) {
  std::vector<int> positions;
  for (const auto& name : names) {
    const auto it = std::find(classes.begin(), classes.end(), name);
    if (it == classes.end())
      throw file.empty() ? Error("", "--channels", "names " + name + ", a class the work folders do not have")
                         : Error(file, "classes", "have no class " + name + " (named by --channels)");
    positions.push_back(int(it - classes.begin()));
  }
  return positions;
}

cv::Mat hog_grid_descriptors(const cv::Mat& bgr, cv::Size window) {
  if (bgr.empty() || bgr.type() != CV_8UC3) throw Error("", "image", "HOG classes need a non-empty 8-bit BGR image");
  if (!valid_window(window)) throw Error("", "window", "is " + size_text(window) + ", expected " + kWindowRule);
  const cv::HOGDescriptor hog = hog_of(window);
  std::vector<float> d;
  // Padding half a window (a multiple of the 8-pixel stride): window i starts at 8 i - w / 2.
  hog.compute(bgr, d, cv::Size(kHogGridStep, kHogGridStep), cv::Size(window.width / 2, window.height / 2));
  const cv::Size grid = hog_grid_size(bgr.size());
  const int nx = grid.width, ny = grid.height;
  const std::size_t dim = hog.getDescriptorSize();
  if (d.size() != dim * std::size_t(nx) * std::size_t(ny))
    throw Error("", "image", "HOG gave " + std::to_string(d.size() / dim) + " windows, expected " + std::to_string(nx * ny));
  return cv::Mat(nx * ny, int(dim), CV_32FC1, d.data()).clone();
}

HogClassifier learn_hog_classifier(HogSamples s, const HogLearning& o) {
  HogClassifier model;
  model.window = o.window;
  model.classes = s.classes;
  model.channels = o.channels;
  const int n = s.descriptors.rows, dim = s.descriptors.cols, classes = int(s.classes.size());
  std::vector<bool> whole(classes, false);  // a class without samples learns a low probability everywhere
  for (int c : class_positions(s.classes, o.channels, "")) whole[std::size_t(c)] = true;
  if (n == 0) throw Error("", "WORK", "no labelled grid point in the frames");
  // z-scores (in place: the samples are the model's largest memory), sums in sample order
  cv::Mat& z = s.descriptors;
  for (int i = 0; i < dim; ++i) {
    double sum = 0, sum2 = 0;
    for (int r = 0; r < n; ++r) sum += z.ptr<float>(r)[i];
    const double mean = sum / n;
    for (int r = 0; r < n; ++r) sum2 += (z.ptr<float>(r)[i] - mean) * (z.ptr<float>(r)[i] - mean);
    const double sd = std::sqrt(sum2 / n);
    model.mean.push_back(mean);
    model.scale.push_back(sd > 0 ? 1.0 / sd : 1.0);
  }
  standardise(z, model.mean, model.scale);
  const std::vector<double> weight = class_weights(s, whole, o.negatives);
  model.weights = cv::Mat::zeros(classes, dim, CV_64FC1);
  model.bias.assign(classes, 0.0);
  Adam adam{cv::Mat::zeros(classes, dim + 1, CV_64FC1), cv::Mat::zeros(classes, dim + 1, CV_64FC1)};
  std::mt19937_64 rng(o.seed);
  std::vector<double> p(classes);
  cv::Mat grad(classes, dim + 1, CV_64FC1);
  for (int epoch = 0; epoch < o.epochs; ++epoch) {
    const std::vector<int> order = shuffled(n, rng);
    for (int start = 0; start < n; start += kBatch) {
      const int end = std::min(n, start + kBatch);
      grad.setTo(0.0);
      for (int k = start; k < end; ++k) {
        const float* zr = z.ptr<float>(order[k]);
        const int label = s.labels[order[k]];
        softmax(zr, model.weights, model.bias, p);
        for (int c = 0; c < classes; ++c) {
          const double g = weight[label] * (p[c] - (c == label ? 1.0 : 0.0));
          double* gc = grad.ptr<double>(c);
          for (int i = 0; i < dim; ++i) gc[i] += g * zr[i];
          gc[dim] += g;
        }
      }
      grad /= double(end - start);
      for (int c = 0; c < classes; ++c)
        for (int i = 0; i < dim; ++i) grad.at<double>(c, i) += o.l2 * model.weights.at<double>(c, i);
      adam_step(grad, o.learning_rate, adam, model.weights, model.bias);
    }
  }
  return model;
}

std::vector<cv::Mat> hog_class_rasters(const cv::Mat& bgr, const HogClassifier& model) {
  cv::Mat z = hog_grid_descriptors(bgr, model.window);
  if (z.cols != model.descriptor_size())
    throw Error("", "image", "HOG descriptors of " + std::to_string(z.cols) + " entries, the model's " +
                                 std::to_string(model.descriptor_size()));
  standardise(z, model.mean, model.scale);
  const std::vector<int> written = class_positions(model.classes, model.channels, "");
  const cv::Size grid_size = hog_grid_size(bgr.size());
  const int nx = grid_size.width, ny = grid_size.height;
  std::vector<cv::Mat> grid(written.size());
  for (auto& g : grid) g.create(ny, nx, CV_64FC1);
  std::vector<double> p(model.classes.size());
  for (int r = 0; r < z.rows; ++r) {
    softmax(z.ptr<float>(r), model.weights, model.bias, p);
    for (std::size_t k = 0; k < written.size(); ++k) grid[k].at<double>(r / nx, r % nx) = p[written[k]];
  }
  // Bilinear between the grid points around each pixel (point (i, j) is pixel (8 i, 8 j)), in 1/255
  // steps: stored as bytes (frame_values.cpp keeps the smallest exact type), a 480x360 frame's five
  // channels take tens of kB instead of 5 MB as doubles.
  std::vector<cv::Mat> out(written.size());
  for (std::size_t k = 0; k < written.size(); ++k) {
    out[k].create(bgr.size(), CV_64FC1);
    for (int y = 0; y < bgr.rows; ++y) {
      const int j = std::min(y / kHogGridStep, ny - 2);
      const double fy = double(y - j * kHogGridStep) / kHogGridStep;
      for (int x = 0; x < bgr.cols; ++x) {
        const int i = std::min(x / kHogGridStep, nx - 2);
        const double fx = double(x - i * kHogGridStep) / kHogGridStep;
        const cv::Mat& g = grid[k];
        const double p = (1 - fy) * ((1 - fx) * g.at<double>(j, i) + fx * g.at<double>(j, i + 1)) +
                         fy * ((1 - fx) * g.at<double>(j + 1, i) + fx * g.at<double>(j + 1, i + 1));
        out[k].at<double>(y, x) = std::round(kProbabilitySteps * p);
      }
    }
  }
  return out;
}

void save_hog_classifier(const fs::path& path, const HogClassifier& m) {
  Json weights = Json::array();
  for (int c = 0; c < m.weights.rows; ++c) {
    const double* w = m.weights.ptr<double>(c);
    weights.push_back(std::vector<double>(w, w + m.weights.cols));
  }
  write_json_atomic(path, {{"format", kHogClassesFormat},
                           {"version", kModelVersion},
                           {"window", {m.window.width, m.window.height}},
                           {"classes", m.classes},
                           {"channels", m.channels},
                           {"mean", m.mean},
                           {"scale", m.scale},
                           {"weights", weights},
                           {"bias", m.bias},
                           {"provenance", m.provenance}});
}

namespace {

std::vector<std::string> names_of(const JsonView& a) {
  std::vector<std::string> v;
  for (std::size_t i = 0; i < a.size(); ++i) v.push_back(a.at(i).as_str());
  return v;
}

}  // namespace

HogClassifier load_hog_classifier(const fs::path& path) {
  const Json j = read_json(path);
  const JsonView v(j, path);
  check_format(v, kHogClassesFormat, {kModelVersion});
  HogClassifier m;
  const JsonView window = v.at("window");
  if (window.size() != 2) window.fail("expected [width, height]");
  m.window = cv::Size(int(window.at(0).as_integer()), int(window.at(1).as_integer()));
  if (!valid_window(m.window)) window.fail("is " + size_text(m.window) + ", expected " + kWindowRule);
  m.classes = names_of(v.at("classes"));
  m.channels = names_of(v.at("channels"));
  for (std::size_t k = 0; k < m.channels.size(); ++k)
    if (std::find(m.classes.begin(), m.classes.end(), m.channels[k]) == m.classes.end())
      v.at("channels").at(k).fail("is not one of classes");
  if (m.classes.size() < 2) v.at("classes").fail("expected at least two classes");
  const std::size_t dim = hog_of(m.window).getDescriptorSize();
  m.mean = finite_numbers(v.at("mean"), dim);
  m.scale = finite_numbers(v.at("scale"), dim);
  for (std::size_t i = 0; i < dim; ++i)
    if (!(m.scale[i] > 0)) v.at("scale").at(i).fail("must be > 0");
  const JsonView weights = v.at("weights");
  if (weights.size() != m.classes.size()) weights.fail("expected a row per class");
  m.weights.create(int(m.classes.size()), int(dim), CV_64FC1);
  for (std::size_t c = 0; c < m.classes.size(); ++c) {
    const std::vector<double> row = finite_numbers(weights.at(c), dim);
    std::copy(row.begin(), row.end(), m.weights.ptr<double>(int(c)));
  }
  m.bias = finite_numbers(v.at("bias"), m.classes.size());
  if (const auto p = v.maybe("provenance")) m.provenance = p->json();
  return m;
}

}  // namespace smseg::stacks
