#include "smseg/eval/metrics.hpp"

#include <cmath>
#include <cstdio>
#include <limits>

#include <algorithm>
#include <set>

#include <opencv2/imgproc.hpp>

#include "smseg/common/error.hpp"
#include "smseg/common/io.hpp"

namespace smseg::eval {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}

Confusion::Confusion(int classes) : n_(classes), counts_(std::size_t(classes) * classes, 0) {}

void Confusion::add(const cv::Mat& truth, const cv::Mat& predicted) {
  CV_Assert(truth.type() == CV_8UC1 && predicted.type() == CV_8UC1 && truth.size() == predicted.size());
  for (int y = 0; y < truth.rows; ++y) {
    const std::uint8_t* t = truth.ptr<std::uint8_t>(y);
    const std::uint8_t* p = predicted.ptr<std::uint8_t>(y);
    for (int x = 0; x < truth.cols; ++x) {
      if (t[x] == 255) continue;
      if (t[x] >= n_ || p[x] >= n_)
        throw Error("", "labels", "class id " + std::to_string(std::max(t[x], p[x])) + " outside the " +
                                      std::to_string(n_) + " classes");
      ++counts_[std::size_t(t[x]) * n_ + p[x]];
    }
  }
}

void Confusion::add(int truth, int predicted, std::int64_t count) {
  if (truth < 0 || truth >= n_ || predicted < 0 || predicted >= n_)
    throw Error("", "labels", "class id outside the class list");
  counts_[std::size_t(truth) * n_ + predicted] += count;
}

void Confusion::merge(const Confusion& other) {
  if (other.n_ != n_) throw Error("", "confusion", "class counts differ");
  for (std::size_t i = 0; i < counts_.size(); ++i) counts_[i] += other.counts_[i];
}

std::int64_t Confusion::total() const {
  std::int64_t s = 0;
  for (auto c : counts_) s += c;
  return s;
}

std::int64_t Confusion::row_total(int truth) const {
  std::int64_t s = 0;
  for (int p = 0; p < n_; ++p) s += at(truth, p);
  return s;
}

double Confusion::global_accuracy() const {
  const auto t = total();
  if (t == 0) return kNaN;
  std::int64_t right = 0;
  for (int c = 0; c < n_; ++c) right += at(c, c);
  return double(right) / double(t);
}

std::vector<double> Confusion::recall() const {
  std::vector<double> r(n_, kNaN);
  for (int c = 0; c < n_; ++c) {
    const auto row = row_total(c);
    if (row > 0) r[c] = double(at(c, c)) / double(row);
  }
  return r;
}

std::vector<double> Confusion::iou() const {
  std::vector<double> r(n_, kNaN);
  for (int c = 0; c < n_; ++c) {
    std::int64_t fp = 0, fn = 0;
    for (int k = 0; k < n_; ++k) {
      if (k == c) continue;
      fn += at(c, k);
      fp += at(k, c);
    }
    const auto denom = at(c, c) + fp + fn;
    if (denom > 0) r[c] = double(at(c, c)) / double(denom);
  }
  return r;
}

namespace {
double nan_mean(const std::vector<double>& v) {
  double s = 0;
  int n = 0;
  for (double x : v)
    if (!std::isnan(x)) {
      s += x;
      ++n;
    }
  return n ? s / n : kNaN;
}
nlohmann::json num_or_null(double v) { return std::isnan(v) ? nlohmann::json(nullptr) : nlohmann::json(v); }
}  // namespace

double Confusion::class_average_accuracy() const { return nan_mean(recall()); }
double Confusion::mean_iou() const { return nan_mean(iou()); }

nlohmann::json Confusion::counts_json() const {
  nlohmann::json rows = nlohmann::json::array();
  for (int t = 0; t < n_; ++t) {
    nlohmann::json row = nlohmann::json::array();
    for (int p = 0; p < n_; ++p) row.push_back(at(t, p));
    rows.push_back(row);
  }
  return rows;
}

nlohmann::json Confusion::normalised_json() const {
  nlohmann::json rows = nlohmann::json::array();
  for (int t = 0; t < n_; ++t) {
    const auto total_row = row_total(t);
    nlohmann::json row = nlohmann::json::array();
    for (int p = 0; p < n_; ++p) row.push_back(num_or_null(total_row ? double(at(t, p)) / double(total_row) : kNaN));
    rows.push_back(row);
  }
  return rows;
}

std::string Confusion::table(const std::vector<std::string>& names) const {
  std::string out;
  char buf[64];
  std::snprintf(buf, sizeof buf, "%-12s", "truth\\output");
  out += buf;
  for (int p = 0; p < n_; ++p) {
    std::snprintf(buf, sizeof buf, " %9.9s", p < int(names.size()) ? names[p].c_str() : "?");
    out += buf;
  }
  out += "\n";
  for (int t = 0; t < n_; ++t) {
    std::snprintf(buf, sizeof buf, "%-12.12s", t < int(names.size()) ? names[t].c_str() : "?");
    out += buf;
    const auto total_row = row_total(t);
    for (int p = 0; p < n_; ++p) {
      if (total_row == 0) {
        std::snprintf(buf, sizeof buf, " %9s", "-");
      } else {
        std::snprintf(buf, sizeof buf, " %8.1f%%", 100.0 * double(at(t, p)) / double(total_row));
      }
      out += buf;
    }
    out += "\n";
  }
  return out;
}

CostMatrix CostMatrix::load(const std::filesystem::path& path, const std::vector<std::string>& classes) {
  return from_json(read_json(path), path, classes);
}

CostMatrix CostMatrix::from_json(const nlohmann::json& j, const std::filesystem::path& file,
                                 const std::vector<std::string>& classes) {
  const JsonView v(j, file);
  check_format(v, "smseg-costs", {1});
  const JsonView names = v.at("classes");
  const std::size_t n = names.size();
  std::vector<std::string> file_classes;
  for (std::size_t i = 0; i < n; ++i) file_classes.push_back(names.at(i).as_str());
  // Names must be exactly the forest's classes (each once, any order).
  std::vector<int> pos(classes.size(), -1);
  for (std::size_t i = 0; i < n; ++i) {
    const auto it = std::find(classes.begin(), classes.end(), file_classes[i]);
    if (it == classes.end())
      names.at(i).fail("class \"" + file_classes[i] + "\" is not a class of the forest");
    const auto k = static_cast<std::size_t>(it - classes.begin());
    if (pos[k] >= 0) names.at(i).fail("class \"" + file_classes[i] + "\" appears twice");
    pos[k] = static_cast<int>(i);
  }
  for (std::size_t k = 0; k < classes.size(); ++k)
    if (pos[k] < 0) names.fail("the forest's class \"" + classes[k] + "\" has no row and column");
  const JsonView rows = v.at("costs");
  if (rows.size() != n) rows.fail("expected " + std::to_string(n) + " rows, one per class");
  std::vector<double> raw(n * n);
  for (std::size_t t = 0; t < n; ++t) {
    const JsonView row = rows.at(t);
    if (row.size() != n) row.fail("expected " + std::to_string(n) + " costs, one per class");
    for (std::size_t p = 0; p < n; ++p) {
      const double c = row.at(p).as_num();
      if (!std::isfinite(c) || c < 0) row.at(p).fail("a cost must be a finite number >= 0");
      if (t == p && c != 0) row.at(p).fail("a right label costs nothing: the diagonal must be 0");
      raw[t * n + p] = c;
    }
  }
  CostMatrix m;
  m.classes = classes;
  m.cost.resize(n * n);
  for (std::size_t t = 0; t < n; ++t)
    for (std::size_t p = 0; p < n; ++p) m.cost[t * n + p] = raw[std::size_t(pos[t]) * n + std::size_t(pos[p])];
  return m;
}

double mean_cost(const Confusion& confusion, const CostMatrix& costs) {
  if (static_cast<std::size_t>(confusion.classes()) != costs.classes.size())
    throw Error("", "costs", "the cost matrix has another number of classes than the confusion matrix");
  const auto total = confusion.total();
  if (total == 0) return kNaN;
  double sum = 0;
  for (int t = 0; t < confusion.classes(); ++t)
    for (int p = 0; p < confusion.classes(); ++p) sum += double(confusion.at(t, p)) * costs.at(t, p);
  return sum / double(total);
}

std::int64_t near_misses(const cv::Mat& truth, const cv::Mat& predicted, int tolerance) {
  CV_Assert(truth.type() == CV_8UC1 && predicted.type() == CV_8UC1 && truth.size() == predicted.size());
  if (tolerance < 0) throw Error("", "--tolerance", "must be >= 0");
  if (tolerance == 0) return 0;
  // Wrong, non-void pixels and the output classes they took.
  const cv::Mat wrong = (truth != predicted) & (truth != 255);
  std::set<int> taken;
  for (int y = 0; y < truth.rows; ++y) {
    const std::uint8_t* w = wrong.ptr<std::uint8_t>(y);
    const std::uint8_t* p = predicted.ptr<std::uint8_t>(y);
    for (int x = 0; x < truth.cols; ++x)
      if (w[x]) taken.insert(p[x]);
  }
  if (taken.empty()) return 0;
  // A disc of radius T: a pixel is near class c when a truth pixel of c lies at distance <= T.
  const int T = tolerance;
  cv::Mat disc(2 * T + 1, 2 * T + 1, CV_8UC1);
  for (int i = 0; i < disc.rows; ++i)
    for (int k = 0; k < disc.cols; ++k) disc.at<std::uint8_t>(i, k) = (i - T) * (i - T) + (k - T) * (k - T) <= T * T;
  std::int64_t near = 0;
  cv::Mat near_c;
  for (int c : taken) {
    cv::dilate(truth == c, near_c, disc, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0));
    near += cv::countNonZero(near_c & wrong & (predicted == c));
  }
  return near;
}

}  // namespace smseg::eval
