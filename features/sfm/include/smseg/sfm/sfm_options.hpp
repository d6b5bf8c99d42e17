#pragma once
// SfmOptions' table (smseg/common/options.hpp): the fields users set, declared once.
#include "smseg/sfm/sfm.hpp"

namespace smseg::options {
template <class S>
class Table;  // smseg/common/options.hpp
}

namespace smseg::sfm {

/// extract-features' SfM options, run-experiment's extraction keys and Python's extract_features take
/// these fields through ExtractOptions' table, which includes this one; the other fields of SfmOptions
/// keep their defaults.
const options::Table<SfmOptions>& sfm_options_table();

}  // namespace smseg::sfm
