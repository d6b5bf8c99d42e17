#include "smseg/eval/metrics.hpp"

#include <cmath>
#include <cstdio>
#include <limits>

#include "smseg/error.hpp"

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

}  // namespace smseg::eval
