// smseg::forest alone: a forest grown on a table whose class is its first column's sign.
#include <cstdint>
#include <iostream>
#include <vector>

#include "smseg/forest/tabular.hpp"

int main() {
  using namespace smseg::forest;
  std::vector<float> values;
  std::vector<std::uint8_t> labels;
  for (int i = 0; i < 200; ++i) {
    const float x = float(i - 100) / 10.0f, noise = float((i * 37) % 11) / 11.0f;
    values.insert(values.end(), {x, noise});
    labels.push_back(x < 0 ? 0 : 1);
  }
  const auto trees = grow_tabular_forest(values, 2, labels, 2, 5, 2, 1, Score::WehenkelPavella);
  std::vector<double> acc;
  const float negative[] = {-3.0f, 0.5f}, positive[] = {3.0f, 0.5f};
  const int a = tabular_posterior(trees, negative, 2, acc), b = tabular_posterior(trees, positive, 2, acc);
  std::cout << trees.size() << " trees; -3 -> class " << a << ", 3 -> class " << b << "\n";
  return a == 0 && b == 1 ? 0 : 1;
}
