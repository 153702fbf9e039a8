// quadid._quadid: the C++ side of the Python module (python/quadid/__init__.py
// wraps it; docs/python.md). Options arrive as a dict keyed by the command
// line's long names and are read by the library (options_json.hpp), so the
// names, defaults and checks are the CLI's. Results are the commands' JSON
// as Python objects; signals are numpy arrays that VIEW the library's
// column-major matrices (no copy): each array keeps its owner alive through
// a capsule.
#include "quadid/batch.hpp"
#include "quadid/design.hpp"
#include "quadid/identification.hpp"
#include "quadid/io.hpp"
#include "quadid/pipeline.hpp"
#include "quadid/models.hpp"
#include "quadid/online.hpp"
#include "quadid/precision.hpp"
#include "quadid/simulation.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <sstream>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>

namespace py = pybind11;
using json = nlohmann::ordered_json;

namespace {

// --- JSON <-> Python -------------------------------------------------------------

bool is_num(const json& e) { return (e.is_number() && !e.is_boolean()) || e.is_null(); }

/// A non-empty JSON array of numbers (null read as NaN: the JSON's non-finite
/// numbers), or of equally long such arrays, as a float64 numpy array (1-D or
/// 2-D); nullopt for anything else (strings, objects, mixed, all null).
std::optional<py::object> numeric_array(const json& j) {
  if (j.empty()) return std::nullopt;
  auto value = [](const json& e) { return e.is_null() ? std::numeric_limits<double>::quiet_NaN() : e.get<double>(); };
  bool any_number = false;
  if (std::all_of(j.begin(), j.end(), [&](const json& e) { any_number |= e.is_number(); return is_num(e); })) {
    if (!any_number) return std::nullopt;
    py::array_t<double> a(static_cast<py::ssize_t>(j.size()));
    auto m = a.mutable_unchecked<1>();
    for (std::size_t i = 0; i < j.size(); ++i) m(static_cast<py::ssize_t>(i)) = value(j[i]);
    return py::object(std::move(a));
  }
  const std::size_t cols = j[0].is_array() ? j[0].size() : 0;
  if (cols == 0) return std::nullopt;
  for (const auto& row : j)
    if (!row.is_array() || row.size() != cols || !std::all_of(row.begin(), row.end(), is_num)) return std::nullopt;
  py::array_t<double> a({static_cast<py::ssize_t>(j.size()), static_cast<py::ssize_t>(cols)});
  auto m = a.mutable_unchecked<2>();
  for (std::size_t r = 0; r < j.size(); ++r)
    for (std::size_t c = 0; c < cols; ++c) m(static_cast<py::ssize_t>(r), static_cast<py::ssize_t>(c)) = value(j[r][c]);
  return py::object(std::move(a));
}

py::object to_py(const json& j) {
  switch (j.type()) {
    case json::value_t::null: return py::none();
    case json::value_t::boolean: return py::bool_(j.get<bool>());
    case json::value_t::number_integer: return py::int_(j.get<long long>());
    case json::value_t::number_unsigned: return py::int_(j.get<unsigned long long>());
    case json::value_t::number_float: {
      const double x = j.get<double>();
      // `quadid ... --json` prints a non-finite number as null; so does this.
      return std::isfinite(x) ? py::object(py::float_(x)) : py::object(py::none());
    }
    case json::value_t::string: return py::str(j.get_ref<const std::string&>());
    case json::value_t::array: {
      if (auto a = numeric_array(j)) return *a;  // numbers (and null = NaN): a numpy array
      py::list l;
      for (const auto& e : j) l.append(to_py(e));
      return l;
    }
    case json::value_t::object: {
      py::dict d;
      for (const auto& [k, v] : j.items()) d[py::str(k)] = to_py(v);
      return d;
    }
    default: return py::none();
  }
}

json from_py(const py::handle& o, const std::string& where) {
  if (o.is_none()) return nullptr;
  if (py::isinstance<py::bool_>(o)) return o.cast<bool>();
  if (py::isinstance<py::str>(o)) return o.cast<std::string>();
  if (py::hasattr(o, "__fspath__")) return py::str(o.attr("__fspath__")()).cast<std::string>();
  // numpy before the number tests: an array has __float__ too (for size 1 only)
  if (py::hasattr(o, "tolist") && py::hasattr(o, "ndim")) return from_py(o.attr("tolist")(), where);  // numpy
  if (py::isinstance<py::int_>(o) || (py::hasattr(o, "__index__") && !py::isinstance<py::float_>(o)))
    return py::int_(py::reinterpret_borrow<py::object>(o)).cast<long long>();
  if (py::isinstance<py::float_>(o) || py::hasattr(o, "__float__")) return py::float_(py::reinterpret_borrow<py::object>(o)).cast<double>();
  if (py::isinstance<py::list>(o) || py::isinstance<py::tuple>(o)) {
    json a = json::array();
    for (const auto& e : o) a.push_back(from_py(e, where));
    return a;
  }
  if (py::isinstance<py::dict>(o)) {  // e.g. identify()'s result handed back to model()
    json obj = json::object();
    for (const auto& [k, v] : py::reinterpret_borrow<py::dict>(o)) obj[py::str(k).cast<std::string>()] = from_py(v, where);
    return obj;
  }
  throw py::value_error("option " + where + ": unsupported value of type " +
                        py::str(py::type::of(o).attr("__name__")).cast<std::string>());
}

json options_json(const py::dict& d) {
  json j = json::object();
  for (const auto& [k, v] : d) {
    const std::string key = py::str(k).cast<std::string>();
    j[key] = from_py(v, "'" + key + "'");
  }
  return j;
}

// --- Zero-copy column views ----------------------------------------------------------

/// A dict {column name: numpy array} whose arrays view the columns of `data`
/// (column-major, so each column is contiguous); the matrix lives as long as
/// any of the arrays.
py::dict column_views(std::shared_ptr<const Eigen::MatrixXd> data, const std::vector<std::string>& names) {
  auto* keep = new std::shared_ptr<const Eigen::MatrixXd>(data);
  py::capsule owner(keep, [](void* p) { delete static_cast<std::shared_ptr<const Eigen::MatrixXd>*>(p); });
  py::dict d;
  const auto rows = static_cast<py::ssize_t>(data->rows());
  for (std::size_t c = 0; c < names.size(); ++c) {
    py::array_t<double> a({rows}, {static_cast<py::ssize_t>(sizeof(double))},
                          data->data() + static_cast<Eigen::Index>(c) * data->rows(), owner);
    a.attr("setflags")(py::arg("write") = false);  // read-only: the library's memory
    d[py::str(names[c])] = a;
  }
  return d;
}

py::dict log_views(quadid::FlightLog&& log) {
  auto data = std::make_shared<const Eigen::MatrixXd>(std::move(log.data));
  return column_views(std::move(data), log.columns);
}

/// A FlightLog from a mapping of column name -> 1-D array: the columns the
/// identification reads (the standard ones, after `map` renames) are copied
/// once into the library's column-major matrix; the others are not touched.
quadid::FlightLog log_from_mapping(const py::object& mapping, const quadid::CsvReadOptions& csv) {
  quadid::FlightLog log;
  const auto& required = csv.required;
  Eigen::Index n = -1;
  std::vector<py::array_t<double, py::array::c_style | py::array::forcecast>> cols;
  for (const auto& canonical : required) {
    const auto it = csv.map.find(canonical);
    const std::string name = it == csv.map.end() ? canonical : it->second;
    if (!py::bool_(mapping.attr("__contains__")(py::str(name))))
      throw quadid::InputError("log: missing column '" + name + "'" +
                               (name != canonical ? " (mapped to '" + canonical + "')" : std::string()));
    auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(mapping[py::str(name)]);
    if (!a) throw quadid::InputError("log: column '" + name + "' is not convertible to an array of numbers");
    if (a.ndim() != 1)
      throw quadid::InputError("log: column '" + name + "' has " + std::to_string(a.ndim()) +
                               " dimensions, expected 1");
    if (n < 0) n = a.shape(0);
    if (a.shape(0) != n)
      throw quadid::InputError("log: column '" + name + "' has " + std::to_string(a.shape(0)) + " samples, column '" +
                               log.columns.front() + "' has " + std::to_string(n));
    log.columns.push_back(canonical);
    cols.push_back(std::move(a));
  }
  log.data.resize(n, static_cast<Eigen::Index>(cols.size()));
  for (std::size_t c = 0; c < cols.size(); ++c)
    log.data.col(static_cast<Eigen::Index>(c)) = Eigen::Map<const Eigen::VectorXd>(cols[c].data(), n);
  return log;
}

// --- The commands ------------------------------------------------------------------

py::dict read_log(const std::string& path, const std::vector<std::string>& map,
                  std::optional<double> period_tolerance, const std::string& time_unit) {
  quadid::CsvReadOptions csv;  // the standard columns are required, the others kept
  csv.map = quadid::parse_column_map(map);
  csv.time_units_per_second = quadid::parse_time_unit(time_unit);
  if (period_tolerance) csv.period_tolerance = *period_tolerance;  // else the reader's default, as the CLI's
  quadid::FlightLog log;
  {
    py::gil_scoped_release nogil;
    log = quadid::load_log_file(path, csv);
  }
  return log_views(std::move(log));
}

// `quadid import FILE` as arrays: {"columns": {name: array}, "report": the import report}.
py::dict import_log(const std::string& path, double rate_hz, const std::string& vehicle) {
  quadid::logs::LoadOptions lo;
  lo.import.rate_hz = rate_hz;
  lo.import.validate();
  lo.check_required = false;
  quadid::logs::ImportReport rep;
  quadid::FlightLog log;
  {
    py::gil_scoped_release nogil;
    if (quadid::logs::detect_log_kind(path) == quadid::logs::LogKind::Csv)
      throw quadid::InputError(path + ": byte 0: not an autopilot log (a flight-log CSV needs no import: read_log reads it)");
    log = quadid::logs::load_any_log(path, lo, &rep);
    // With a vehicle: its rotor model's wrench too (Fz, tau_*, Omega_r), as identify computes it.
    if (!vehicle.empty()) log = quadid::with_rotor_wrench(log, quadid::load_vehicle(vehicle).rotors);
  }
  py::dict out;
  out["columns"] = log_views(std::move(log));
  out["report"] = to_py(quadid::logs::import_report_json(rep));
  return out;
}

py::dict identify(const py::object& log, const py::dict& opts) {
  const quadid::IdentifyRequest req = quadid::identify_options_from_json(options_json(opts));
  json j;
  quadid::Evolution evo;
  if (py::isinstance<py::str>(log) || py::hasattr(log, "__fspath__")) {
    const std::string path = py::str(py::isinstance<py::str>(log) ? log : log.attr("__fspath__")());
    py::gil_scoped_release nogil;
    j = quadid::identify_log_file(path, req, &evo);
  } else {
    if (!py::hasattr(log, "keys") || !py::hasattr(log, "__getitem__"))
      throw py::type_error("identify: log must be a path or a mapping of column name -> array");
    // The columns a file would need (with a vehicle: its rotor columns),
    // then the same preparation as a file: windows, rotor model, timing.
    quadid::CsvReadOptions csv = req.csv;
    csv.required = quadid::identification_columns(req);
    const quadid::FlightLog fl = log_from_mapping(log, csv);
    py::gil_scoped_release nogil;
    const quadid::IdentificationInput in = quadid::prepare_identification(fl, req);
    quadid::IdentificationResult res = quadid::identify_prepared(in);
    j = quadid::to_json(res);
    quadid::add_input_json(j, in);
    j["log"] = nullptr;  // the command's "log" is the file's name; a mapping has none
    evo = std::move(res.evolution);
  }
  py::dict d = to_py(j).cast<py::dict>();
  auto data = std::make_shared<const Eigen::MatrixXd>(std::move(evo.data));
  d["evolution"] = column_views(std::move(data), evo.columns);
  return d;
}

py::dict simulate(const py::dict& opts, bool truth, const std::string& out, const std::string& truth_out) {
  quadid::SimulateRequest req = quadid::simulate_options_from_json(options_json(opts));
  req.options.record_truth = truth || !truth_out.empty();
  quadid::SimulationResult res;
  {
    py::gil_scoped_release nogil;
    res = quadid::simulate(*req.trajectory, req.options);
    if (!truth_out.empty()) quadid::write_flight_log(res.truth, truth_out);
    if (!out.empty()) quadid::write_flight_log(res.log, out);
  }
  py::dict d;
  d["trajectory"] = quadid::trajectory_spec(*req.trajectory);
  d["options"] = to_py(quadid::to_json(req.options));
  d["summary"] = to_py(quadid::to_json(res.summary));
  d["comments"] = py::cast(res.log.comments);
  d["log"] = log_views(std::move(res.log));
  d["truth"] = req.options.record_truth ? py::object(log_views(std::move(res.truth))) : py::object(py::none());
  return d;
}

py::dict design(const py::dict& opts, const std::string& out) {
  const quadid::DesignRequest req = quadid::design_request(quadid::OptionValues(options_json(opts), "design"));
  const quadid::DesignOptions& opt = req.options;
  json j;
  {
    py::gil_scoped_release nogil;
    const quadid::DesignResult res = quadid::design_trajectory(opt);
    if (!res.check.all_hold())  // the message of `quadid design`
      throw std::runtime_error(quadid::infeasible_design_message(res, opt));
    j = quadid::design_to_json(res, opt);
    if (req.precision.predict) {  // as `quadid design`
      try {
        j["predicted_precision"] = quadid::to_json(quadid::predict_precision(res.trajectory, req.precision.options));
        j["predicted_precision"]["flown_by"] = req.precision.flown;
      } catch (const quadid::InputError& e) {
        j["predicted_precision"] = {{"error", e.what()}};
      }
    }
    if (!out.empty()) quadid::write_file_atomic(out, j.dump(2) + "\n");
  }
  return to_py(j).cast<py::dict>();
}

py::dict check_trajectory(const std::string& trajectory, const py::dict& opts) {
  // As the command line: a designed file's own limits, those given here in place of its values.
  const quadid::CheckRequest req =
      quadid::check_request(quadid::OptionValues(options_json(opts), "check-trajectory"), trajectory);
  json j;
  {
    py::gil_scoped_release nogil;
    const auto traj = quadid::load_trajectory(trajectory);
    j = quadid::to_json(quadid::check_trajectory(*traj, req.options));
    if (req.precision.predict) {
      try {
        j["predicted_precision"] = quadid::to_json(quadid::predict_precision(*traj, req.precision.options));
      } catch (const quadid::InputError& e) {
        j["predicted_precision"] = {{"error", e.what()}};
      }
    }
    j["source"] = trajectory;
    j["limits"] = quadid::to_json(req.options.limits);
    j["limits_from"] = req.limits_from;
  }
  return to_py(j).cast<py::dict>();
}

py::dict validate(const std::string& log, const py::dict& opts, py::object warn) {
  const quadid::ValidateRequest req = quadid::validate_options_from_json(options_json(opts));
  std::vector<std::string> notes;
  json j;
  {
    py::gil_scoped_release nogil;
    const quadid::FlightLog fl = quadid::load_validation_log(log, req);
    j = quadid::to_json(quadid::validate_log(fl, req, [&](const std::string& s) { notes.push_back(s); }), log);
  }
  for (const auto& s : notes) warn(s);
  return to_py(j).cast<py::dict>();
}

py::list option_specs(const std::string& command) {
  py::list l;
  for (const auto& d : quadid::option_table(command).options) {
    const char* kind = "string";
    switch (d.kind) {
      case quadid::OptionKind::Number: kind = "number"; break;
      case quadid::OptionKind::Integer: kind = "integer"; break;
      case quadid::OptionKind::String: kind = "string"; break;
      case quadid::OptionKind::Window: kind = "window"; break;
      case quadid::OptionKind::Flag: kind = "flag"; break;
      case quadid::OptionKind::List: kind = "list"; break;
    }
    py::dict e;
    e["name"] = d.name;
    e["kind"] = kind;
    e["help"] = d.full_help();
    e["default"] = d.default_value.empty() ? py::object(py::none()) : py::object(py::str(d.default_value));
    e["default_text"] = d.default_text.empty() ? d.default_value : d.default_text;
    e["unit"] = d.unit;
    e["choices"] = d.choices;
    e["aliases"] = d.aliases;
    e["range"] = d.range_text();
    e["cli_only"] = d.scope == quadid::OptionScope::Cli;
    l.append(e);
  }
  return l;
}

}  // namespace

// --- Online estimation (quadid follow) --------------------------------------------

/// quadid.OnlineEstimator: the library's OnlineEstimator with follow's options.
class PyOnline {
 public:
  explicit PyOnline(const py::dict& options) : est_(online_from(options)) {}
  /// One sample: a dict {t, x, y, z, phi, theta, psi, p, q, r, Fz, tau_phi,
  /// tau_theta, tau_psi[, Omega_r]} or 14 (15) numbers in that order.
  bool update(const py::object& row) {
    quadid::StreamSample s;
    double v[15] = {};
    const auto& names = quadid::standard_log_columns();
    if (py::isinstance<py::dict>(row)) {
      const py::dict d = row.cast<py::dict>();
      for (size_t i = 0; i < names.size(); ++i) {
        if (!d.contains(names[i].c_str()))
          throw py::value_error(fmt::format("OnlineEstimator.update: the row has no '{}' (needs {})", names[i],
                                            fmt::join(names, " ")));
        v[i] = d[names[i].c_str()].cast<double>();
      }
      if (d.contains(quadid::kRotorMomentumColumn)) v[14] = d[quadid::kRotorMomentumColumn].cast<double>();
    } else {
      const std::vector<double> x = row.cast<std::vector<double>>();
      if (x.size() != 14 && x.size() != 15)
        throw py::value_error(fmt::format("OnlineEstimator.update: {} numbers; expected 14 ({}) or 15 (then Omega_r)",
                                          x.size(), fmt::join(names, " ")));
      std::copy(x.begin(), x.end(), v);
    }
    s.t = v[0];
    s.position = quadid::Vec3(v[1], v[2], v[3]);
    s.attitude = quadid::Vec3(v[4], v[5], v[6]);
    s.rates = quadid::Vec3(v[7], v[8], v[9]);
    s.wrench = quadid::Vec4(v[10], v[11], v[12], v[13]);
    s.omega_r = v[14];
    if (est_.update(s)) track_.push_back(est_.tracking());
    return est_.changed();
  }
  py::object estimate() const { return to_py(quadid::to_json(est_.estimate())); }
  py::object tracking() const { return to_py(quadid::to_json(est_.tracking())); }
  py::object result() const { return to_py(quadid::follow_json(est_, track_)); }
  bool changed() const { return est_.changed(); }

 private:
  static quadid::OnlineOptions online_from(const py::dict& options) {
    const quadid::FollowRequest r = quadid::follow_request(quadid::OptionValues(options_json(options), "follow"));
    return quadid::online_options(r.identify.options, r.online);
  }
  quadid::OnlineEstimator est_;
  std::vector<quadid::OnlineEstimate> track_;  // one per closed block
};

PYBIND11_MODULE(_quadid, m) {
  m.doc() = "quadid's C++ library (use the quadid package, which wraps this module)";
  m.attr("__version__") = QUADID_VERSION;
  // Bad data in a log or file: a ValueError, with the library's message (file, line, column).
  py::register_exception<quadid::InputError>(m, "InputError", PyExc_ValueError);
  // A simulated flight that left the safe region.
  py::register_exception<quadid::SimulationDiverged>(m, "SimulationDiverged", PyExc_RuntimeError);
  // A library Options field in an error reads as the keyword that sets it
  // ("cutoff=300", not "LowpassOptions: cutoff_hz=300" or "--cutoff").
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const std::invalid_argument& e) {
      const std::string msg = quadid::with_option_names(e.what(), quadid::OptionSource::Json);
      PyErr_SetString(PyExc_ValueError, msg.c_str());
    }
  });
  m.def("read_log", &read_log, py::arg("path"), py::arg("map"), py::arg("period_tolerance"), py::arg("time_unit"));
  m.def("identify", &identify, py::arg("log"), py::arg("options"));
  m.def("import_log", &import_log, py::arg("path"), py::arg("rate_hz"), py::arg("vehicle"));
  m.def("simulate", &simulate, py::arg("options"), py::arg("truth"), py::arg("out"), py::arg("truth_out"));
  m.def("design", &design, py::arg("options"), py::arg("out"));
  m.def("check_trajectory", &check_trajectory, py::arg("trajectory"), py::arg("options"));
  m.def("validate", &validate, py::arg("log"), py::arg("options"), py::arg("warn"));
  m.def("option_specs", &option_specs, py::arg("command"));
  py::class_<PyOnline>(m, "OnlineEstimator")
      .def(py::init<const py::dict&>(), py::arg("options"))
      .def("update", &PyOnline::update, py::arg("row"))
      .def("estimate", &PyOnline::estimate)
      .def("tracking", &PyOnline::tracking)
      .def("result", &PyOnline::result)
      .def_property_readonly("changed", &PyOnline::changed);
  m.def(
      "follow",
      [](const std::string& path, const py::dict& options) {
        const quadid::FollowRequest r = quadid::follow_request(quadid::OptionValues(options_json(options), "follow"));
        std::istringstream none;
        return to_py(quadid::follow(path, r, none, {}, {}));
      },
      py::arg("path"), py::arg("options"));
  m.def(
      "log_info",
      [](const std::string& path, bool allow_truncated) { return to_py(quadid::log_info_json(path, allow_truncated)); },
      py::arg("path"), py::arg("allow_truncated"));
  m.def(
      "check_identify_options",
      [](const py::dict& opts) { (void)quadid::identify_options_from_json(options_json(opts)); },
      py::arg("options"), "raises ValueError for an option identify would reject");
  m.def("normalize_option_key", &quadid::normalize_option_key, py::arg("key"));
  m.def(
      "model",
      [](const py::object& result, const std::string& format, const std::string& set, double sih_scale,
         bool mjcf_motor_lag, const std::string& flavour) {
        const quadid::ModelFormat f = quadid::parse_model_format(format);
        quadid::ModelOptions opt;
        opt.sih_scale = sih_scale;
        opt.mjcf_motor_lag = mjcf_motor_lag;
        opt.urdf_flavour = flavour;
        const quadid::IdentifiedModel im =
            py::isinstance<py::dict>(result)
                ? quadid::identified_model_from_json(from_py(result, "result"), "the result dict", set)
                : quadid::load_identified_model(from_py(result, "result").get<std::string>(), set);
        for (const auto& w : quadid::model_warnings(im, f, opt))
          PyErr_WarnEx(PyExc_UserWarning, w.c_str(), 1);
        return quadid::model_text(im, f, opt);
      },
      py::arg("result"), py::arg("format"), py::arg("set"), py::arg("sih_scale"), py::arg("mjcf_motor_lag"),
      py::arg("flavour"));
  m.def(
      "summarize_fleet",
      [](const std::string& records_json, const std::string& set, double level) {
        const auto records = json::parse(records_json).get<std::vector<json>>();  // quadid.fleet (json.dumps)
        return to_py(quadid::to_json(quadid::summarize_fleet(records, {set, level})));
      },
      py::arg("records_json"), py::arg("set"), py::arg("level"));
  m.def(
      "fleet_report",
      [](const std::string& records_json, const std::string& set, double level) {
        const auto records = json::parse(records_json).get<std::vector<json>>();  // quadid.fleet (json.dumps)
        std::vector<quadid::FleetPageLog> logs;
        for (const auto& r : records) logs.push_back(quadid::fleet_page_log(r));
        return quadid::fleet_report(quadid::summarize_fleet(records, {set, level}), logs);
      },
      py::arg("records_json"), py::arg("set"), py::arg("level"));
}
