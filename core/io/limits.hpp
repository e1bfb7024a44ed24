// Named size limits (docs/architecture.md "Robustness"): each has a default a laptop survives and an
// environment variable that raises it. Checked before anything of that size is allocated.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

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
inline constexpr Limit kMaxInputFile{"bytes per model or sweep file", "HYSID_MAX_INPUT_FILE", 16 << 20};
inline constexpr Limit kMaxCsvRows{"data rows per CSV file", "HYSID_MAX_CSV_ROWS", 50'000'000};
// Exact convex hulls of C and D (the identifier's sets) grow exponentially with the dimension:
// above this many states the sets are not computed (IdentifyResult says why).
inline constexpr Limit kMaxHullDimension{"states for the exact hulls of C and D", "HYSID_MAX_HULL_DIMENSION",
                                         6};

// The limit's value: the environment variable when set (a positive integer), else the default.
// Throws std::invalid_argument naming the variable when it is set but not a positive integer.
std::int64_t LimitValue(const Limit& limit);

// Throws std::invalid_argument "`where`: VALUE exceeds the limit of N WHAT (raise it with VAR=N)"
// when value > LimitValue(limit).
void CheckLimit(const Limit& limit, std::int64_t value, const std::string& where);

// a · b, or the limit's error when the product overflows 64 bits or exceeds the limit.
std::int64_t CheckedProduct(const Limit& limit, std::int64_t a, std::int64_t b, const std::string& where);

// A UTF-8 byte order mark: skipped at the start of a CSV or TOML input.
inline constexpr std::string_view kUtf8Bom = "\xEF\xBB\xBF";

// Throws std::invalid_argument "PATH: is a FIFO, not a regular file ..." for anything but a regular
// file (or a missing one: opening it reports that): reading a FIFO, socket or device could block
// forever or never end. `what` names the input ("data file").
void CheckRegularFile(const std::string& path, const char* what);

// `text` with control bytes, DEL and bytes that are not valid UTF-8 written as \xNN.
std::string Printable(std::string_view text);
// `text` cut to `max` bytes with its full length appended, then Printable, for echoing input in messages.
std::string Abbreviated(std::string_view text, std::size_t max = 60);
// A whole message longer than `max` bytes: its first two thirds and its last third of `max` kept,
// "… (N bytes cut) …" between them, then Printable; the reason at a message's end stays readable
// after a long echoed path or expression.
std::string ShortenedMessage(std::string_view text, std::size_t max);

}  // namespace hysid
