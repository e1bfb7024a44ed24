// A model file with candidate terms ([flow], [[flow]], [jump] or [[jump]] candidates) turned into the chosen model: the
// candidates kept become ordinary α entries with their φ columns (β entries with their ψ columns), the others are
// dropped, and the values given replace the entries' values; a flow table with a kept term loses its jacobian_constant
// (the model with candidates is not declared constant either). The result is a model file without candidates (docs/model-files.md).
#pragma once

#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace hysid {

// `text`: the file with candidates (`name` stands for it in errors); `kept`: the names (ROW_K, MODE_ROW_K, jump_ROW_K, MAP_ROW_K) of the
// candidates to keep; `values`: parameter name → value, for α, β (top-level or a map's) and guard
// parameters; `header`: comment lines written first (each without '#'). Throws std::invalid_argument
// for a kept name that is no candidate of the file.
std::string ChosenModelText(std::string_view text, const std::string& name, const std::vector<std::string>& kept,
                            const std::map<std::string, double>& values, const std::vector<std::string>& header = {});

}  // namespace hysid
