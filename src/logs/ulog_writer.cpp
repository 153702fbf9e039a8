// A small ULog writer (same format description as ulog.cpp): tests build
// files from data with it, and simulated flights can be written as PX4 logs.
#include "quadid/logs.hpp"

#include "bytes.hpp"

#include "frames.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace quadid::logs {
using detail::put;

ULogWriter::ULogWriter(std::uint64_t start_timestamp_us) {
  out_.append("ULog\x01\x12\x35", 7);
  out_.push_back('\x01');  // version
  put(out_, start_timestamp_us);
  // Flag bits: no compat/incompat flags, no appended data.
  message('B', std::string(40, '\0'));
}

void ULogWriter::message(char type, std::string_view payload) {
  if (payload.size() > std::numeric_limits<std::uint16_t>::max())
    throw std::invalid_argument(fmt::format("ULog message '{}' of {} bytes: at most 65535", type, payload.size()));
  put(out_, static_cast<std::uint16_t>(payload.size()));
  out_.push_back(type);
  out_.append(payload);
}

void ULogWriter::raw(char type, std::string_view payload) { message(type, payload); }

void ULogWriter::format(std::string_view definition) {
  if (data_section_) throw std::logic_error("ULogWriter: formats must come before the first subscription");
  const auto colon = definition.find(':');
  if (colon == std::string_view::npos || colon == 0)
    throw std::invalid_argument(fmt::format("ULog format '{}': expected name:type field;...", definition));
  formats_[std::string(definition.substr(0, colon))] = true;
  message('F', definition);
}

void ULogWriter::key_value(char type, std::string_view prefix, std::string_view type_key, std::string_view value) {
  if (type_key.size() > 255) throw std::invalid_argument(fmt::format("ULog key '{}' longer than 255 bytes", type_key));
  std::string p(prefix);
  p.push_back(static_cast<char>(type_key.size()));
  p.append(type_key);
  p.append(value);
  message(type, p);
}

void ULogWriter::info(std::string_view key, std::string_view text) {
  key_value('I', "", fmt::format("char[{}] {}", text.size(), key), text);
}
void ULogWriter::info(std::string_view key, std::int32_t value) {
  key_value('I', "", fmt::format("int32_t {}", key), ULogPayload().put(value).str());
}
void ULogWriter::info(std::string_view key, std::uint32_t value) {
  key_value('I', "", fmt::format("uint32_t {}", key), ULogPayload().put(value).str());
}
void ULogWriter::info_multiple(std::string_view key, std::string_view text, bool continued) {
  key_value('M', std::string(1, continued ? '\1' : '\0'), fmt::format("char[{}] {}", text.size(), key), text);
}
void ULogWriter::parameter(std::string_view name, float value) {
  key_value('P', "", fmt::format("float {}", name), ULogPayload().put(value).str());
}
void ULogWriter::parameter(std::string_view name, std::int32_t value) {
  key_value('P', "", fmt::format("int32_t {}", name), ULogPayload().put(value).str());
}
void ULogWriter::default_parameter(std::uint8_t default_types, std::string_view name, float value) {
  key_value('Q', std::string(1, static_cast<char>(default_types)), fmt::format("float {}", name),
            ULogPayload().put(value).str());
}

std::uint16_t ULogWriter::subscribe(std::string_view format_name, std::uint8_t multi_id) {
  if (!formats_.count(std::string(format_name)))
    throw std::logic_error(fmt::format("ULogWriter: no format '{}' defined", format_name));
  data_section_ = true;
  const std::uint16_t id = next_msg_id_++;
  std::string p(1, static_cast<char>(multi_id));
  put(p, id);
  p.append(format_name);
  message('A', p);
  return id;
}

void ULogWriter::data(std::uint16_t msg_id, std::string_view payload) {
  if (msg_id >= next_msg_id_) throw std::logic_error(fmt::format("ULogWriter: msg id {} not subscribed", msg_id));
  std::string p;
  put(p, msg_id);
  p.append(payload);
  message('D', p);
}

void ULogWriter::logged(char level, std::uint64_t timestamp_us, std::string_view msg) {
  data_section_ = true;
  std::string p(1, level);
  put(p, timestamp_us);
  p.append(msg);
  message('L', p);
}

void ULogWriter::logged_tagged(char level, std::uint16_t tag, std::uint64_t timestamp_us, std::string_view msg) {
  data_section_ = true;
  std::string p(1, level);
  put(p, tag);
  put(p, timestamp_us);
  p.append(msg);
  message('C', p);
}

void ULogWriter::dropout(std::uint16_t duration_ms) {
  data_section_ = true;
  message('O', ULogPayload().put(duration_ms).str());
}

void ULogWriter::sync() {
  data_section_ = true;
  message('S', std::string("\x2F\x73\x13\x20\x25\x0C\xBB\x12", 8));
}

void ULogWriter::write(const std::filesystem::path& path) const { write_file_atomic(path, out_); }

}  // namespace quadid::logs

namespace quadid::logs {

std::string px4_ulog_from_flight_log(const FlightLog& log, const Px4UlogWriteOptions& opt) {
  for (const std::string c : {"t", "x", "y", "z", "phi", "theta", "psi", "p", "q", "r"})
    if (!log.has(c) && (opt.write_position || (c != "x" && c != "y" && c != "z")))
      throw InputError(fmt::format("px4_ulog_from_flight_log: the flight log has no column '{}'", c));
  if (opt.motor_columns.size() > 12)
    throw std::invalid_argument(fmt::format("{} motor columns: actuator_motors holds at most 12", opt.motor_columns.size()));
  if (opt.output_columns.size() > 16)
    throw std::invalid_argument(fmt::format("{} output columns: actuator_outputs holds at most 16", opt.output_columns.size()));
  ULogWriter w(opt.start_timestamp_us);
  w.info("sys_name", "PX4");
  w.info("ver_hw", "QUADID_SIM");
  w.format("vehicle_local_position:uint64_t timestamp;float x;float y;float z;");
  w.format("vehicle_attitude:uint64_t timestamp;float[4] q;");
  w.format("vehicle_angular_velocity:uint64_t timestamp;float[3] xyz;uint8_t[4] _padding0;");
  w.format("actuator_motors:uint64_t timestamp;float[12] control;");
  w.format("vehicle_acceleration:uint64_t timestamp;float[3] xyz;uint8_t[4] _padding0;");
  w.format("actuator_outputs:uint64_t timestamp;uint32_t noutputs;float[16] output;");
  for (const auto& [name, value] : opt.int_parameters) w.parameter(name, value);
  const RotorGeometry& g = opt.geometry;
  if (g.count > 0) {
    w.parameter("CA_ROTOR_COUNT", std::int32_t{g.count});
    for (int i = 0; i < g.count; ++i) {
      const auto k = static_cast<std::size_t>(i);
      // FLU -> FRD; KM > 0 for a counter-clockwise rotor.
      const Eigen::Vector3d frd = detail::flu_to_frd(g.position[k]);
      w.parameter(fmt::format("CA_ROTOR{}_PX", i), static_cast<float>(frd.x()));
      w.parameter(fmt::format("CA_ROTOR{}_PY", i), static_cast<float>(frd.y()));
      w.parameter(fmt::format("CA_ROTOR{}_PZ", i), static_cast<float>(frd.z()));
      if (k < g.ct.size()) w.parameter(fmt::format("CA_ROTOR{}_CT", i), static_cast<float>(g.ct[k]));
      if (k < g.km.size() && k < g.spin.size())
        w.parameter(fmt::format("CA_ROTOR{}_KM", i), static_cast<float>(g.spin[k] == "cw" ? -g.km[k] : g.km[k]));
    }
  }
  const bool accel = log.has("ax_b") && log.has("ay_b") && log.has("az_b");
  const std::uint16_t pos = opt.write_position ? w.subscribe("vehicle_local_position") : 0;
  const std::uint16_t acc = accel ? w.subscribe("vehicle_acceleration") : 0;
  const auto att = w.subscribe("vehicle_attitude");
  const auto rat = w.subscribe("vehicle_angular_velocity");
  const std::uint16_t mot = opt.motor_columns.empty() ? 0 : w.subscribe("actuator_motors");
  const std::uint16_t outs = opt.output_columns.empty() ? 0 : w.subscribe("actuator_outputs");
  const auto col = [&log](std::string_view c) { return log.column(c); };
  const auto col_or_zero = [&log](std::string_view c) {
    return log.has(c) ? log.column(c) : Eigen::VectorXd(Eigen::VectorXd::Zero(log.rows()));
  };
  const Eigen::VectorXd t = col("t"), x = col_or_zero("x"), y = col_or_zero("y"), z = col_or_zero("z"),
                        phi = col("phi"), theta = col("theta"), psi = col("psi"), p = col("p"), q = col("q"),
                        r = col("r"), ax = col_or_zero("ax_b"), ay = col_or_zero("ay_b"), az = col_or_zero("az_b");
  std::vector<Eigen::VectorXd> motors;
  for (const auto& c : opt.motor_columns) motors.push_back(col(c));
  std::vector<Eigen::VectorXd> outputs;
  for (const auto& c : opt.output_columns) outputs.push_back(col(c));
  for (Eigen::Index i = 0; i < t.size(); ++i) {
    const auto ts = opt.start_timestamp_us + static_cast<std::uint64_t>(std::llround((t[i] - t[0]) * 1e6));
    if (opt.write_position) {
      const Eigen::Vector3d p_ned = detail::flu_to_frd(Eigen::Vector3d(x[i], y[i], z[i]));
      w.data(pos, ULogPayload().put(ts).put(float(p_ned.x())).put(float(p_ned.y())).put(float(p_ned.z())).str());
    }
    if (accel) {
      const Eigen::Vector3d a_frd = detail::flu_to_frd(Eigen::Vector3d(ax[i], ay[i], az[i]));
      w.data(acc, ULogPayload().put(ts).put(float(a_frd.x())).put(float(a_frd.y())).put(float(a_frd.z())).str());
    }
    // ZYX Euler -> quaternion (body FLU -> world z up), then (q0, q1, -q2, -q3).
    const Eigen::Vector4d qa = detail::quaternion_from_euler_zyx(phi[i], theta[i], psi[i]);
    const double q0 = qa[0], q1 = qa[1], q2 = qa[2], q3 = qa[3];
    w.data(att, ULogPayload().put(ts).put(float(q0)).put(float(q1)).put(float(-q2)).put(float(-q3)).str());
    const Eigen::Vector3d rates_frd = detail::flu_to_frd(Eigen::Vector3d(p[i], q[i], r[i]));
    w.data(rat, ULogPayload().put(ts).put(float(rates_frd.x())).put(float(rates_frd.y())).put(float(rates_frd.z())).str());
    if (!motors.empty()) {
      ULogPayload m;
      m.put(ts);
      for (std::size_t k = 0; k < 12; ++k) m.put(k < motors.size() ? float(motors[k][i]) : NAN);
      w.data(mot, m.str());
    }
    if (!outputs.empty()) {
      ULogPayload o;
      o.put(ts).put(static_cast<std::uint32_t>(outputs.size()));
      for (std::size_t k = 0; k < 16; ++k) o.put(k < outputs.size() ? float(outputs[k][i]) : 0.0f);
      w.data(outs, o.str());
    }
  }
  return w.bytes();
}

}  // namespace quadid::logs
