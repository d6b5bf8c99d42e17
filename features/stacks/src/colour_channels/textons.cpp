#include "smseg/stacks/textons.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <opencv2/imgproc.hpp>

#include "smseg/common/error.hpp"
#include "smseg/stacks/appearance.hpp"
#include "learned_files.hpp"

namespace smseg::stacks {

namespace {

constexpr int kDictionaryVersion = 1;  // of the "smseg-textons" file
constexpr const char* kFilterBankName = "winn17-lab";  // the header's bank: a file of another is refused

cv::Mat gaussian(const cv::Mat& plane, double sigma) {
  cv::Mat out;
  cv::GaussianBlur(plane, out, cv::Size(), sigma, sigma, cv::BORDER_REFLECT_101);
  return out;
}

/// Squared distance of a z-scored row to a centre.
float distance2(const float* z, const float* centre) {
  float d = 0;
  for (int i = 0; i < kFilterBankSize; ++i) d += (z[i] - centre[i]) * (z[i] - centre[i]);
  return d;
}

/// The nearest centre (the lower index on a tie).
int nearest(const float* z, const cv::Mat& centres) {
  int best = 0;
  float best_d = std::numeric_limits<float>::infinity();
  for (int k = 0; k < centres.rows; ++k) {
    const float d = distance2(z, centres.ptr<float>(k));
    if (d < best_d) best_d = d, best = k;
  }
  return best;
}

/// Rows of `samples` as z-scores (mean, scale per column).
cv::Mat z_scores(const cv::Mat& samples, const std::vector<double>& mean, const std::vector<double>& scale) {
  cv::Mat z(samples.size(), CV_32FC1);
  for (int r = 0; r < samples.rows; ++r) {
    const float* s = samples.ptr<float>(r);
    float* out = z.ptr<float>(r);
    for (int i = 0; i < kFilterBankSize; ++i) out[i] = static_cast<float>((s[i] - mean[i]) * scale[i]);
  }
  return z;
}

/// k-means++ seeding (Arthur & Vassilvitskii 2007): each next centre drawn with probability proportional
/// to the squared distance to the nearest centre so far. Sums run in sample order: the same draw
/// whatever the thread count.
cv::Mat seed_centres(const cv::Mat& z, int k, std::uint64_t seed) {
  std::mt19937_64 gen(seed);
  const auto uniform = [&gen] { return static_cast<double>(gen() >> 11) * 0x1.0p-53; };  // [0, 1)
  cv::Mat centres(k, kFilterBankSize, CV_32FC1);
  z.row(static_cast<int>(gen() % static_cast<std::uint64_t>(z.rows))).copyTo(centres.row(0));
  std::vector<float> d2(z.rows, std::numeric_limits<float>::infinity());
  for (int c = 1; c < k; ++c) {
    const float* last = centres.ptr<float>(c - 1);
    tbb::parallel_for(tbb::blocked_range<int>(0, z.rows), [&](const tbb::blocked_range<int>& r) {
      for (int i = r.begin(); i < r.end(); ++i) d2[i] = std::min(d2[i], distance2(z.ptr<float>(i), last));
    });
    double total = 0;
    for (float d : d2) total += d;
    double target = uniform() * total;
    int pick = z.rows - 1;
    for (int i = 0; i < z.rows; ++i)
      if ((target -= d2[i]) < 0) {
        pick = i;
        break;
      }
    z.row(pick).copyTo(centres.row(c));
  }
  return centres;
}

/// Lloyd's iterations: assignment in parallel, each centre the mean of its samples summed in order (a
/// centre that loses every sample stays where it was). Stops when no sample changes its centre.
void lloyd(const cv::Mat& z, cv::Mat& centres, int iterations) {
  std::vector<int> label(z.rows, -1);
  for (int it = 0; it < iterations; ++it) {
    std::vector<char> moved(z.rows, 0);
    tbb::parallel_for(tbb::blocked_range<int>(0, z.rows), [&](const tbb::blocked_range<int>& r) {
      for (int i = r.begin(); i < r.end(); ++i) {
        const int k = nearest(z.ptr<float>(i), centres);
        moved[i] = k != label[i];
        label[i] = k;
      }
    });
    if (std::none_of(moved.begin(), moved.end(), [](char m) { return m != 0; })) return;
    cv::Mat sums = cv::Mat::zeros(centres.rows, kFilterBankSize, CV_64FC1);
    std::vector<long> members(centres.rows, 0);
    for (int i = 0; i < z.rows; ++i) {
      const float* row = z.ptr<float>(i);
      double* s = sums.ptr<double>(label[i]);
      for (int d = 0; d < kFilterBankSize; ++d) s[d] += row[d];
      ++members[label[i]];
    }
    for (int k = 0; k < centres.rows; ++k)
      if (members[k] > 0)
        for (int d = 0; d < kFilterBankSize; ++d)
          centres.ptr<float>(k)[d] = static_cast<float>(sums.ptr<double>(k)[d] / members[k]);
  }
}

}  // namespace

std::vector<std::string> TextonDictionary::feature_names() const {
  std::vector<std::string> names;
  for (int k = 0; k < count(); ++k) names.push_back(kTextonPrefix + std::to_string(k));
  return names;
}

bool is_texton_feature(const std::string& name) {
  if (name.rfind(kTextonPrefix, 0) != 0 || name.size() == std::string(kTextonPrefix).size()) return false;
  return name.find_first_not_of("0123456789", std::string(kTextonPrefix).size()) == std::string::npos;
}

cv::Mat filter_bank_responses(const cv::Mat& bgr) {
  if (bgr.empty() || bgr.type() != CV_8UC3) throw Error("", "textons", "needs a colour (8-bit, 3-channel) image");
  std::vector<cv::Mat> lab;
  append_lab_rasters(bgr, lab);
  for (cv::Mat& plane : lab) plane.convertTo(plane, CV_32F);
  std::vector<cv::Mat> responses;
  for (double sigma : {1.0, 2.0, 4.0})
    for (const cv::Mat& plane : lab) responses.push_back(gaussian(plane, sigma));
  for (double sigma : {1.0, 2.0, 4.0, 8.0}) {
    cv::Mat log;
    cv::Laplacian(gaussian(lab[0], sigma), log, CV_32F, 1, sigma * sigma, 0, cv::BORDER_REFLECT_101);
    responses.push_back(log);
  }
  for (double sigma : {2.0, 4.0}) {
    const cv::Mat g = gaussian(lab[0], sigma);
    cv::Mat dx, dy;  // central differences [-1 0 1] / 2, times sigma
    cv::Sobel(g, dx, CV_32F, 1, 0, 1, sigma / 2, 0, cv::BORDER_REFLECT_101);
    cv::Sobel(g, dy, CV_32F, 0, 1, 1, sigma / 2, 0, cv::BORDER_REFLECT_101);
    responses.push_back(dx);
    responses.push_back(dy);
  }
  cv::Mat interleaved;
  cv::merge(responses, interleaved);
  return interleaved.reshape(1, bgr.rows * bgr.cols).clone();
}

cv::Mat sample_filter_responses(const cv::Mat& bgr, int count, std::uint64_t seed) {
  const cv::Mat all = filter_bank_responses(bgr);
  std::mt19937_64 gen(seed);
  cv::Mat samples(count, kFilterBankSize, CV_32FC1);
  for (int i = 0; i < count; ++i) all.row(static_cast<int>(gen() % static_cast<std::uint64_t>(all.rows))).copyTo(samples.row(i));
  return samples;
}

TextonDictionary learn_textons(const cv::Mat& samples, const TextonLearning& o) {
  if (o.textons < 2 || o.textons > kMaxTextons)
    throw Error("", "--textons", "is " + std::to_string(o.textons) + ", expected 2.." + std::to_string(kMaxTextons));
  if (samples.type() != CV_32FC1 || samples.cols != kFilterBankSize || samples.rows < o.textons)
    throw Error("", "samples", std::to_string(samples.rows) + " samples for " + std::to_string(o.textons) +
                                   " textons: need at least one per texton");
  TextonDictionary d;
  for (int i = 0; i < kFilterBankSize; ++i) {
    double sum = 0, sum2 = 0;
    for (int r = 0; r < samples.rows; ++r) sum += samples.ptr<float>(r)[i];
    const double mean = sum / samples.rows;
    for (int r = 0; r < samples.rows; ++r) sum2 += (samples.ptr<float>(r)[i] - mean) * (samples.ptr<float>(r)[i] - mean);
    const double sd = std::sqrt(sum2 / samples.rows);
    d.mean.push_back(mean);
    d.scale.push_back(sd > 0 ? 1.0 / sd : 1.0);
  }
  const cv::Mat z = z_scores(samples, d.mean, d.scale);
  d.centres = seed_centres(z, o.textons, o.seed);
  lloyd(z, d.centres, o.iterations);
  return d;
}

cv::Mat assign_textons(const cv::Mat& bgr, const TextonDictionary& dictionary) {
  const cv::Mat z = z_scores(filter_bank_responses(bgr), dictionary.mean, dictionary.scale);
  cv::Mat index(bgr.size(), CV_8UC1);
  tbb::parallel_for(tbb::blocked_range<int>(0, bgr.rows), [&](const tbb::blocked_range<int>& r) {
    for (int y = r.begin(); y < r.end(); ++y)
      for (int x = 0; x < bgr.cols; ++x)
        index.ptr<std::uint8_t>(y)[x] = static_cast<std::uint8_t>(nearest(z.ptr<float>(y * bgr.cols + x), dictionary.centres));
  });
  return index;
}

std::vector<cv::Mat> texton_rasters(const cv::Mat& index, int count) {
  CV_Assert(index.type() == CV_8UC1);
  std::vector<cv::Mat> rasters(count);
  for (int k = 0; k < count; ++k) {
    cv::Mat on = index == k;  // 255 where texton k
    on.convertTo(rasters[k], CV_64F, 1.0 / 255);
  }
  return rasters;
}

void save_texton_dictionary(const fs::path& path, const TextonDictionary& d) {
  Json centres = Json::array();
  for (int k = 0; k < d.count(); ++k) {
    const float* c = d.centres.ptr<float>(k);
    centres.push_back(std::vector<double>(c, c + kFilterBankSize));
  }
  write_json_atomic(path, {{"format", kTextonFormat},
                           {"version", kDictionaryVersion},
                           {"filter_bank", kFilterBankName},
                           {"textons", d.count()},
                           {"mean", d.mean},
                           {"scale", d.scale},
                           {"centres", centres},
                           {"provenance", d.provenance}});
}

TextonDictionary load_texton_dictionary(const fs::path& path) {
  const Json j = read_json(path);
  const JsonView v(j, path);
  check_format(v, kTextonFormat, {kDictionaryVersion});
  if (v.str("filter_bank") != kFilterBankName)
    v.at("filter_bank").fail(std::string("is not ") + kFilterBankName + ", the filter bank this build computes");
  const std::int64_t k = v.integer("textons");
  if (k < 2 || k > kMaxTextons) v.at("textons").fail("expected 2.." + std::to_string(kMaxTextons));
  TextonDictionary d;
  d.mean = finite_numbers(v.at("mean"), kFilterBankSize);
  d.scale = finite_numbers(v.at("scale"), kFilterBankSize);
  for (std::size_t i = 0; i < d.scale.size(); ++i)
    if (!(d.scale[i] > 0)) v.at("scale").at(i).fail("must be > 0");
  const JsonView centres = v.at("centres");
  if (centres.size() != static_cast<std::size_t>(k))
    centres.fail("has " + std::to_string(centres.size()) + " centres, expected textons = " + std::to_string(k));
  d.centres.create(static_cast<int>(k), kFilterBankSize, CV_32FC1);
  for (int c = 0; c < k; ++c) {
    const std::vector<double> row = finite_numbers(centres.at(static_cast<std::size_t>(c)), kFilterBankSize);
    for (int i = 0; i < kFilterBankSize; ++i) d.centres.ptr<float>(c)[i] = static_cast<float>(row[i]);
  }
  if (const auto p = v.maybe("provenance")) d.provenance = p->json();
  return d;
}

}  // namespace smseg::stacks
