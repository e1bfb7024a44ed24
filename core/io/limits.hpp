// Named size limits (docs/architecture.md "Robustness"): each has a default a laptop survives and an
// environment variable that raises it. Checked before anything of that size is allocated.
#pragma once

#include <cstdint>
#include <string>

namespace hysid {

struct Limit {
  const char* what;      // "units of a sweep (cells × trials)"
  const char* variable;  // "HYSID_MAX_TRIALS"
  std::int64_t default_value;
};

inline constexpr Limit kMaxTrials{"units per sweep (cells × trials)", "HYSID_MAX_TRIALS", 10'000'000};
inline constexpr Limit kMaxAxisValues{"values per grid axis", "HYSID_MAX_AXIS_VALUES", 100'000};
inline constexpr Limit kMaxCells{"cells per sweep", "HYSID_MAX_CELLS", 1'000'000};
inline constexpr Limit kMaxSamples{"samples per trajectory (t_end/dt + 1)", "HYSID_MAX_SAMPLES", 50'000'000};
inline constexpr Limit kMaxCsvLine{"bytes per CSV line", "HYSID_MAX_CSV_LINE", 1 << 20};
inline constexpr Limit kMaxCsvCell{"bytes per CSV cell", "HYSID_MAX_CSV_CELL", 4096};

// The limit's value: the environment variable when set (a positive integer), else the default.
// Throws std::invalid_argument naming the variable when it is set but not a positive integer.
std::int64_t LimitValue(const Limit& limit);

// Throws std::invalid_argument "`where`: VALUE exceeds the limit of N WHAT (raise it with VAR=N)"
// when value > LimitValue(limit).
void CheckLimit(const Limit& limit, std::int64_t value, const std::string& where);

// a · b, or the limit's error when the product overflows 64 bits or exceeds the limit.
std::int64_t CheckedProduct(const Limit& limit, std::int64_t a, std::int64_t b, const std::string& where);

// `text` with control bytes, DEL and bytes that are not valid UTF-8 written as \xNN.
std::string Printable(std::string_view text);
// `text` cut to `max` bytes with its full length appended, then Printable, for echoing input in messages.
std::string Abbreviated(std::string_view text, std::size_t max = 60);

}  // namespace hysid
