#pragma once
// One name table per enum: the names that options, files and help texts use for its values, written
// once, and the parse and name functions made from it, so that parsing, naming and the list of
// choices in an error cannot drift apart (each enum had its own if-chain, switch and message).
//   constexpr std::array<EnumName<Balance>, 3> kBalanceNames{{{Balance::None, "none"}, ...}};
//   value_named(kBalanceNames, "sqrt", "--balance") -> Balance::Sqrt
//   name_of(kBalanceNames, Balance::Sqrt)            -> "sqrt"
// A bad name is Error(field) 'is "x", expected none, classes or sqrt'.

#include <array>
#include <cstddef>
#include <string>
#include <string_view>

#include "smseg/common/error.hpp"

namespace smseg {

template <class E>
struct EnumName {
  E value;
  std::string_view name;
};

/// "a, b or c": the names in table order.
template <class E, std::size_t N>
std::string name_choices(const std::array<EnumName<E>, N>& table) {
  std::string s;
  for (std::size_t i = 0; i < N; ++i) {
    if (i > 0) s += i + 1 == N ? " or " : ", ";
    s += table[i].name;
  }
  return s;
}

/// The value named `name`; Error naming `field` and the choices when no value has that name.
template <class E, std::size_t N>
E value_named(const std::array<EnumName<E>, N>& table, const std::string& name, const std::string& field) {
  for (const auto& entry : table)
    if (entry.name == name) return entry.value;
  throw Error("", field, "is \"" + name + "\", expected " + name_choices(table));
}

/// The name of `value` (a string literal: null-terminated); "?" for a value the table lacks.
template <class E, std::size_t N>
const char* name_of(const std::array<EnumName<E>, N>& table, E value) {
  for (const auto& entry : table)
    if (entry.value == value) return entry.name.data();
  return "?";
}

}  // namespace smseg
