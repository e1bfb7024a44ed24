#include "python/binding.hpp"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <algorithm>
#include <regex>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/builtin/builtin.hpp"
#include "experiments/request/checks.hpp"
#include "sim/model_check/model_check.hpp"

namespace hysid::python {

const ModelRegistry& Builtins() {
  static const ModelRegistry* registry = [] {
    auto* r = new ModelRegistry;
    RegisterBuiltinModels(*r);
    return r;
  }();
  return *registry;
}

// A Python model may start an identification, so its file's values are start values: a guard its
// default trajectory does not reach is a warning (sim/model_check).
PyModel ModelFromFile(const std::string& path) {
  std::string note;
  PyModel m{LoadModelFile(path, ModelValues::kStart, &note), "", path, ""};
  if (!note.empty() && PyErr_WarnEx(PyExc_UserWarning, note.c_str(), 1) != 0) throw py::error_already_set();
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  m.text = text.str();
  return m;
}

PyModel MakePyModel(const std::string& name_or_file) {
  if (Builtins().Contains(name_or_file)) return {Builtins().Make(name_or_file), name_or_file, "", ""};
  if (std::filesystem::exists(name_or_file)) return ModelFromFile(name_or_file);
  throw std::invalid_argument(NeitherModelNorFile(name_or_file, Builtins().names()));
}

py::tuple ModelState(const PyModel& m) {
  py::dict values;
  const ModelSpec& spec = m.model.spec();
  for (const auto& [params, v] :
       {std::pair{&spec.alpha, &m.model.alpha()}, std::pair{&spec.beta, &m.model.beta()},
        std::pair{&spec.guard_params, &m.model.gamma()}}) {
    for (std::size_t i = 0; i < params->size(); ++i) {
      if (!(*params)[i].known) values[py::str((*params)[i].name)] = (*v)[Eigen::Index(i)];
    }
  }
  return py::make_tuple(m.builtin, m.file, py::bytes(m.text), values);
}

PyModel ModelFromState(const py::tuple& state) {
  if (state.size() != 4) throw std::invalid_argument("hysid.Model: not a pickled model");
  const auto builtin = state[0].cast<std::string>(), file = state[1].cast<std::string>(),
             text = state[2].cast<std::string>();
  PyModel m{builtin.empty() ? ParseModelText(text, file, ModelValues::kStart) : Builtins().Make(builtin), builtin,
            file, text};
  for (const auto& [name, value] : state[3].cast<py::dict>()) {
    m.model.SetParameter(name.cast<std::string>(), value.cast<double>());
  }
  return m;
}

bool SameModel(const PyModel& a, const PyModel& b) {
  return a.builtin == b.builtin && a.text == b.text && a.model.name() == b.model.name() &&
         a.model.alpha() == b.model.alpha() && a.model.beta() == b.model.beta() &&
         a.model.gamma() == b.model.gamma();
}

namespace {

std::string TypeName(const py::handle& value) { return py::str(py::type::handle_of(value).attr("__name__")); }

// "str 'x'": the type and a short repr of a refused value.
std::string Described(const py::handle& value) {
  std::string repr = py::repr(value);
  if (repr.size() > 40) repr = repr.substr(0, 37) + "...";
  return fmt::format("{} {}", TypeName(value), repr);
}

}  // namespace

double Number(const py::handle& value, const std::string& name) {
  // numpy scalars and 0-d arrays are numbers; bool, str, complex and sequences are not.
  if (py::isinstance<py::bool_>(value) || !PyNumber_Check(value.ptr()) || PyComplex_Check(value.ptr())) {
    throw std::invalid_argument(fmt::format("{}: expected a number, got {}", name, Described(value)));
  }
  const py::array_t<double> a = RealArray(value, name);
  if (a.ndim() != 0)
    throw std::invalid_argument(fmt::format("{}: expected a number, got {}", name, Described(value)));
  return *a.data();
}

std::optional<double> OptionalNumber(const py::handle& value, const std::string& name) {
  if (value.is_none()) return std::nullopt;
  return Number(value, name);
}

std::optional<std::string> X0KnownText(const py::handle& value) {
  if (value.is_none()) return std::nullopt;
  if (py::isinstance<py::bool_>(value)) return value.cast<bool>() ? std::optional<std::string>("all") : std::nullopt;
  if (py::isinstance<py::str>(value)) return value.cast<std::string>();
  if (py::isinstance<py::list>(value) || py::isinstance<py::tuple>(value)) {
    std::vector<std::string> names;
    for (const py::handle& n : value) names.push_back(Text(n, "x0_known"));
    return fmt::format("{}", fmt::join(names, ","));
  }
  throw std::invalid_argument(fmt::format(
      "x0_known: expected True, 'all' or state names (a list or comma-separated), got {}", Described(value)));
}

std::vector<std::string> BoundTexts(const py::handle& value) {
  std::vector<std::string> out;
  if (value.is_none()) return out;
  if (!py::isinstance<py::dict>(value))
    throw std::invalid_argument("param_bound: expected a dict {name: (lo, hi)}");
  for (const auto& [key, bounds] : value.cast<py::dict>()) {
    const std::string name = Text(key, "param_bound");
    const std::vector<double> b = Numbers(bounds, fmt::format("param_bound['{}']", name));
    if (b.size() != 2)
      throw std::invalid_argument(fmt::format("param_bound['{}']: expected (lo, hi), got {} values", name, b.size()));
    out.push_back(fmt::format("{}={},{}", name, b[0], b[1]));
  }
  return out;
}




bool IsValueError(const py::error_already_set& e) {
  return e.matches(PyExc_ValueError) || e.matches(PyExc_TypeError);
}

PyModel ModelArgument(const py::handle& value) {
  if (py::isinstance<PyModel>(value)) return value.cast<PyModel>();
  if (py::isinstance<py::str>(value)) return MakePyModel(value.cast<std::string>());
  if (py::hasattr(value, "__fspath__")) return ModelFromFile(py::str(value.attr("__fspath__")()));
  throw std::invalid_argument(
      fmt::format("model: expected a hysid.Model, a built-in model's name or a model file's path, got {}",
                  Described(value)));
}

std::uint64_t Count(const py::handle& value, const std::string& name) {
  if (!py::isinstance<py::int_>(value) || py::isinstance<py::bool_>(value))
    throw std::invalid_argument(fmt::format("{}: expected an integer >= 0, got {}", name, Described(value)));
  std::string text = py::str(value);  // refused as the command line refuses the flag's text
  if (const std::string problem = NonNegativeIntegerProblem(text); !problem.empty()) {
    throw std::invalid_argument(fmt::format("{}: {}", name, problem));
  }
  return value.cast<std::uint64_t>();
}

bool Flag(const py::handle& value, const std::string& name) {
  if (!py::isinstance<py::bool_>(value)) {
    throw std::invalid_argument(fmt::format("{}: expected True or False, got {}", name, Described(value)));
  }
  return value.cast<bool>();
}

std::string Text(const py::handle& value, const std::string& name) {
  if (!py::isinstance<py::str>(value)) {
    throw std::invalid_argument(fmt::format("{}: expected a name (str), got {}", name, Described(value)));
  }
  return value.cast<std::string>();
}

py::array_t<double> RealArray(const py::handle& value, const std::string& name) {
  if (py::isinstance<py::str>(value) || py::isinstance<py::bytes>(value)) {
    throw std::invalid_argument(fmt::format("{}: expected numbers, got {}", name, Described(value)));
  }
  const py::module_ np = py::module_::import("numpy");
  py::array a;
  try {
    a = np.attr("asarray")(value);
  } catch (const py::error_already_set& e) {  // ragged nesting and the like
    if (!IsValueError(e)) throw;  // KeyboardInterrupt (Ctrl-C during the conversion) and the like
    throw std::invalid_argument(fmt::format("{}: not an array of numbers ({})", name, e.what()));
  }
  const char kind = a.dtype().kind();
  if (kind == 'c') {
    throw std::invalid_argument(
        fmt::format("{}: complex values (dtype {}); samples and options are real numbers", name,
                    std::string(py::str(a.dtype()))));
  }
  if (kind != 'f' && kind != 'i' && kind != 'u') {
    throw std::invalid_argument(fmt::format("{}: expected real numbers, got an array of dtype {} ({})", name,
                                            std::string(py::str(a.dtype())), Described(value)));
  }
  return py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
}

std::vector<double> Numbers(const py::handle& value, const std::string& name) {
  if (value.is_none()) return {};
  const py::array_t<double> a = RealArray(value, name);
  if (a.ndim() > 1) {
    throw std::invalid_argument(
        fmt::format("{}: expected a number or a 1-D sequence of numbers, got shape {}", name, ShapeText(a)));
  }
  return std::vector<double>(a.data(), a.data() + a.size());
}

std::string ShapeText(const py::array& a) {
  std::string out = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) out += fmt::format("{}{}", i ? ", " : "", a.shape(i));
  return out + (a.ndim() == 1 ? ",)" : ")");
}

std::string ArrayMessage(const std::string& message, bool runs, int ny, int nu) {
  static const std::regex cell(R"(^run (\d+):(\d+): column (\d+) \('[^']*'\): )");
  static const std::regex column(R"(^run (\d+): column 'y(\d+)': )");
  static const std::regex whole(R"(^run (\d+)(, run \d+)*: )");
  static const std::regex line(R"(line (\d+))");
  std::smatch m;
  auto run = [&](const std::string& r) {
    return runs ? fmt::format("[{}]", std::stol(r) - 1) : std::string();
  };
  if (std::regex_search(message, m, cell)) {
    const std::string r = run(m[1]);
    const long k = std::stol(m[2]) - 1, c = std::stol(m[3]);
    const long i = c - 2;  // the column after t
    const std::string head = c == 1        ? fmt::format("t{}[{}]: ", r, k)
                             : i < ny      ? fmt::format("y{}[{}, {}]: ", r, k, i)
                             : i < ny + nu ? fmt::format("u{}[{}, {}]: ", r, k, i - ny)
                                           : fmt::format("truth['j']{}[{}]: ", r, k);
    std::string rest = m.suffix();
    std::string out;  // "line N" in the rest: the sample N − 1 of the same run
    auto it = rest.cbegin();
    for (std::smatch l; std::regex_search(it, rest.cend(), l, line); it = l.suffix().first) {
      out += std::string(it, l[0].first) + fmt::format("t{}[{}]", r, std::stol(l[1]) - 1);
    }
    return head + out + std::string(it, rest.cend());
  }
  if (std::regex_search(message, m, column)) {
    return fmt::format("y{}[:, {}]: {}", run(m[1]), std::stol(m[2]) - 1, std::string(m.suffix()));
  }
  if (std::regex_search(message, m, whole)) {
    return fmt::format("y{}: {}", m[2].matched ? std::string() : run(m[1]), std::string(m.suffix()));
  }
  return message;
}

py::array_t<double> ToArray(const Vec& v) {
  py::array_t<double> out(v.size());
  if (v.size()) std::memcpy(out.mutable_data(), v.data(), sizeof(double) * std::size_t(v.size()));
  return out;
}

py::array_t<double> Transposed(const Mat& m) {
  py::array_t<double> out({m.cols(), m.rows()});
  if (m.size()) std::memcpy(out.mutable_data(), m.data(), sizeof(double) * std::size_t(m.size()));
  return out;
}

std::atomic<int>& AbandonedWork() {
  static std::atomic<int>* count = new std::atomic<int>(0);  // never destroyed (read at exit)
  return *count;
}

void RegisterExitCheck() {
  py::module_::import("atexit").attr("register")(py::cpp_function([] {
    if (AbandonedWork().load() <= 0) return;
    const py::module_ sys = py::module_::import("sys");
    for (const char* stream : {"stdout", "stderr"}) {
      if (!sys.attr(stream).is_none()) sys.attr(stream).attr("flush")();
    }
    std::fprintf(stderr,
                 "hysid: an interrupted computation is still running; exiting without it (exit code 130)\n");
    std::fflush(nullptr);
    std::_Exit(130);
  }));
}

}  // namespace hysid::python
