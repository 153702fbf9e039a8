// quadid::logs — autopilot logs read natively: PX4 ULog (.ulg) and the
// Crazyflie uSD-card deck's event-based binary log; import of either into a
// flight log (docs/import.md): frame conversion, resampling onto
// one uniform grid with an anti-aliasing filter, gaps reported. See
// docs/log-info.md, docs/import.md and docs/file-formats.md.
//
// Robustness: every reader checks every length against the bytes left; a
// truncated or corrupt file ends in an InputError that names the file, the
// byte offset and what was expected there. Nothing is read past the buffer.
#pragma once

#include "quadid/io.hpp"
#include "quadid/vehicle.hpp"

#include <Eigen/Dense>

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace quadid::logs {

// ============================================================================
// PX4 ULog (PX4 user guide, "ULog File Format"), little endian.
// ============================================================================

/// The basic field types of a ULog format definition.
enum class ULogType : std::uint8_t { Int8, UInt8, Int16, UInt16, Int32, UInt32, Int64, UInt64, Float, Double, Bool, Char };
/// Size in bytes of a basic type.
int ulog_type_size(ULogType t);
/// "int8_t" ... "char" -> type; nullopt for other names (nested types).
std::optional<ULogType> ulog_type_from_name(std::string_view name);

/// A typed value of an info, multi-info or parameter message: the type as
/// written in the file ("int32_t", "float", "char[12]", ...) and the raw bytes.
struct ULogValue {
  std::string type;
  std::string bytes;

  bool is_string() const { return type.rfind("char[", 0) == 0; }
  /// A number (int, float, bool); nullopt for strings, arrays and short values.
  std::optional<double> number() const;
  /// As pyulog prints it: strings as text, integers in decimal, floats as
  /// Python's repr of the value, bool True/False, other types as Python bytes.
  std::string to_string() const;
};

/// One field of a format definition, as written ("float[4] q").
struct ULogFormatField {
  std::string type;    // basic type or name of a nested format
  int array_size = 0;  // 0: scalar
  std::string name;
};
struct ULogFormat {
  std::string name;
  std::vector<ULogFormatField> fields;
};

/// A flattened basic field of a logged topic: nested names joined with '.',
/// arrays as name[i] (e.g. "esc[0].esc_rpm"); padding fields are kept inside
/// the layout but marked, trailing padding is not part of the message.
struct ULogField {
  std::string name;
  ULogType type = ULogType::UInt8;
  std::size_t offset = 0;
  bool padding = false;
};

/// One subscription (add_logged message) and all its data messages.
struct ULogTopic {
  std::string name;
  std::uint8_t multi_id = 0;
  std::uint16_t msg_id = 0;
  std::vector<ULogField> fields;  // flattened, in layout order
  std::size_t size = 0;           // bytes per message without trailing padding
  std::size_t timestamp_offset = 0;
  std::vector<std::uint8_t> data;  // count() messages of `size` bytes each

  std::size_t count() const { return size ? data.size() / size : 0; }
  const ULogField* find(std::string_view field) const;
  /// Timestamps of all messages, microseconds (the topic's `timestamp` field).
  std::vector<std::uint64_t> timestamps() const;
  /// A field of all messages, converted to double; InputError naming the
  /// topic and field when absent.
  Eigen::VectorXd column(std::string_view field) const;
};

struct ULogLoggedMessage {
  char level = '6';                  // '0' emergency .. '7' debug
  std::optional<std::uint16_t> tag;  // tagged logged string ('C')
  std::uint64_t timestamp = 0;       // microseconds
  std::string message;
  /// EMERGENCY ALERT CRITICAL ERROR WARNING NOTICE INFO DEBUG (or UNKNOWN).
  std::string level_name() const;
};

struct ULogDropout {
  std::uint64_t timestamp = 0;  // the last data timestamp before it, microseconds
  std::uint16_t duration_ms = 0;
};

struct ULogParameterChange {
  std::uint64_t timestamp = 0;  // the last data timestamp before it, microseconds
  std::string name;
  ULogValue value;
};

struct ULog {
  std::uint8_t version = 1;
  std::uint64_t start_timestamp = 0;  // header, microseconds
  std::uint64_t last_timestamp = 0;   // largest data timestamp (the header's when none)
  std::array<std::uint8_t, 8> compat_flags{}, incompat_flags{};
  std::vector<std::uint64_t> appended_offsets;  // non-zero ones
  std::map<std::string, ULogFormat> formats;
  std::map<std::string, ULogValue> info;
  /// key -> list of messages, each a list of its continued parts.
  std::map<std::string, std::vector<std::vector<ULogValue>>> info_multiple;
  std::map<std::string, ULogValue> parameters;  // initial values
  std::vector<ULogParameterChange> changed_parameters;
  std::map<std::string, ULogValue> default_parameters_system;  // default_types bit 0
  std::map<std::string, ULogValue> default_parameters_config;  // default_types bit 1
  std::vector<ULogLoggedMessage> logged;  // plain and tagged, in file order
  std::vector<ULogDropout> dropouts;
  std::size_t sync_count = 0;
  std::size_t unknown_messages = 0;  // messages of unknown type, skipped
  std::vector<ULogTopic> topics;     // sorted by name + multi id (pyulog's order)
  /// A cut last message (read with allow_truncated): where it began and the
  /// bytes left after it began; 0, 0 for a complete file.
  std::size_t truncated_at = 0, truncated_bytes = 0;

  const ULogTopic* find_topic(std::string_view name, int multi_id = 0) const;
  /// The current value of a parameter: the last change, else the initial value.
  std::optional<double> parameter(std::string_view name) const;
};

struct ULogReadOptions {
  /// Accept a file whose last message is cut short (the logger stopped by a
  /// power loss): the messages before it are kept. Default: an InputError.
  bool allow_truncated = false;
};

/// True when the bytes start with the ULog magic "ULog\x01\x12\x35".
bool is_ulog(std::span<const std::uint8_t> head);
/// Parses a ULog held in memory; `source` names it in messages.
ULog parse_ulog(std::span<const std::uint8_t> bytes, const std::string& source, const ULogReadOptions& opt = {});
/// Reads and parses a ULog file (the whole file at once).
ULog read_ulog(const std::filesystem::path& path, const ULogReadOptions& opt = {});

/// Builds a ULog file in memory, for tests and simulated flights. Definitions
/// (formats, initial info and parameters) must come before the first
/// subscription; info, parameters, data, strings, dropouts and syncs after.
class ULogWriter {
 public:
  explicit ULogWriter(std::uint64_t start_timestamp_us = 0);
  /// A format definition "name:type field;type field;..." (ULog syntax).
  void format(std::string_view definition);
  void info(std::string_view key, std::string_view text);  // char[N] key
  void info(std::string_view key, std::int32_t value);     // int32_t key
  void info(std::string_view key, std::uint32_t value);    // uint32_t key
  void info_multiple(std::string_view key, std::string_view text, bool continued);
  void parameter(std::string_view name, float value);
  void parameter(std::string_view name, std::int32_t value);
  /// default_types: bit 0 system default, bit 1 current configuration default.
  void default_parameter(std::uint8_t default_types, std::string_view name, float value);
  /// Subscribes a defined format; returns its msg_id.
  std::uint16_t subscribe(std::string_view format_name, std::uint8_t multi_id = 0);
  /// A data message: payload = the fields in layout order (trailing padding may be left out).
  void data(std::uint16_t msg_id, std::string_view payload);
  void logged(char level, std::uint64_t timestamp_us, std::string_view message);
  void logged_tagged(char level, std::uint16_t tag, std::uint64_t timestamp_us, std::string_view message);
  void dropout(std::uint16_t duration_ms);
  void sync();
  /// A message of any type with a raw payload (for tests of unknown types).
  void raw(char type, std::string_view payload);
  const std::string& bytes() const { return out_; }
  /// Writes the file atomically.
  void write(const std::filesystem::path& path) const;

 private:
  void message(char type, std::string_view payload);
  void key_value(char type, std::string_view prefix, std::string_view type_key, std::string_view value);
  std::string out_;
  std::map<std::string, bool> formats_;
  std::uint16_t next_msg_id_ = 0;
  bool data_section_ = false;
};

/// Little-endian payload builder for ULogWriter::data.
class ULogPayload {
 public:
  template <class T>
  ULogPayload& put(T v) {
    static_assert(std::is_arithmetic_v<T>);
    const auto* p = reinterpret_cast<const char*>(&v);
    bytes_.append(p, sizeof(T));  // little-endian host (checked in ulog.cpp)
    return *this;
  }
  ULogPayload& pad(std::size_t n) {
    bytes_.append(n, '\0');
    return *this;
  }
  const std::string& str() const { return bytes_; }

 private:
  std::string bytes_;
};

/// The multicopter geometry from PX4's control-allocation parameters
/// CA_ROTOR_COUNT, CA_ROTORn_PX/PY/PZ (m, body FRD), CA_ROTORn_AX/AY/AZ (thrust
/// axis, default (0,0,-1) FRD), CA_ROTORn_CT (thrust coefficient, N at full
/// command: T = CT u^2 per PX4's model) and CA_ROTORn_KM (moment ratio, m;
/// positive = counter-clockwise seen from above), converted to body FLU.
struct RotorGeometry {
  int count = 0;
  std::vector<Eigen::Vector3d> position;  // m, body FLU (x, -y, -z of FRD)
  std::vector<Eigen::Vector3d> axis;      // unit thrust direction, body FLU
  std::vector<double> ct;                 // CA_ROTORn_CT
  std::vector<double> km;                 // |CA_ROTORn_KM|, m
  std::vector<std::string> spin;          // "ccw" (KM > 0) or "cw" (KM < 0), seen from above
};
/// InputError naming the parameter when CA_ROTOR_COUNT or a rotor's PX/PY is absent.
RotorGeometry px4_rotor_geometry(const ULog& log);

/// A flight log (docs/file-formats.md columns, z up / FLU) as a PX4 ULog in PX4's topics
/// and frames: vehicle_local_position (NED: x, -y, -z), vehicle_attitude
/// (quaternion FRD->NED: q0, q1, -q2, -q3 of the ZYX Euler angles),
/// vehicle_angular_velocity (FRD: p, -q, -r) and, when `motor_columns` are
/// given, actuator_motors.control[i] (unused entries NaN, as PX4 writes them),
/// and actuator_outputs.output[i] when `output_columns` are, all at the log's samples; `geometry` (FLU) becomes the CA_ROTOR*
/// parameters. For simulated PX4 flights and tests of the import.
struct Px4UlogWriteOptions {
  std::vector<std::string> motor_columns;  // log columns, in PX4's motor order
  /// Log columns written as actuator_outputs.output[i] (at most 16), e.g. PWM
  /// pulse widths, or the rotor speed commands of PX4's Gazebo bridge (rad/s).
  std::vector<std::string> output_columns;
  RotorGeometry geometry;                  // count 0: no CA_ROTOR* parameters
  /// Further int32 parameters, e.g. {"SIM_GZ_EN", 1} for a Gazebo simulation.
  std::vector<std::pair<std::string, std::int32_t>> int_parameters;
  std::uint64_t start_timestamp_us = 1'000'000;  // log clock of the first row
  /// false: no vehicle_local_position (a flight without GPS or vision). The log's
  /// ax_b ay_b az_b, when it has them, are always written as vehicle_acceleration (FRD).
  bool write_position = true;
};
std::string px4_ulog_from_flight_log(const FlightLog& log, const Px4UlogWriteOptions& opt = {});

// ============================================================================
// Crazyflie uSD-card deck, event-based logging (../shared/data/crazyflie-usd/README.md)
// ============================================================================

struct UsdVariable {
  std::string name;  // e.g. "stateEstimate.x"
  char type = 'f';   // struct letter: f i I h H b B
};

struct UsdEvent {
  std::uint16_t id = 0;
  std::string name;
  std::vector<UsdVariable> variables;
  std::vector<std::uint64_t> timestamps_us;  // per record (version 1: ms * 1000)
  std::vector<double> values;                // count() x variables.size(), row-major

  std::size_t count() const { return timestamps_us.size(); }
  int find(std::string_view variable) const;
  Eigen::VectorXd column(std::string_view variable) const;  // InputError when absent
  Eigen::VectorXd times() const;                            // seconds
};

struct UsdLog {
  int version = 2;
  std::vector<UsdEvent> events;
  std::uint32_t crc = 0;  // stored = computed (checked)
  /// Read with allow_truncated from a file whose CRC-32 does not match (a
  /// card pulled or power lost mid-write): the records up to the first one
  /// cut or unreadable, which begins at truncated_at (0: a complete file).
  std::size_t truncated_at = 0, truncated_bytes = 0;

  const UsdEvent* find_event(std::string_view name) const;
};

/// CRC-32 as zlib's crc32 (polynomial 0xEDB88320, reflected, init and final xor ~0).
std::uint32_t crc32(std::span<const std::uint8_t> bytes, std::uint32_t crc = 0);
bool is_usd(std::span<const std::uint8_t> head);  // first byte 0xBC
struct UsdReadOptions {
  /// Accept a file without a matching CRC-32 (cut mid-write): its complete records are kept.
  bool allow_truncated = false;
};
UsdLog parse_usd(std::span<const std::uint8_t> bytes, const std::string& source, const UsdReadOptions& opt = {});
UsdLog read_usd(const std::filesystem::path& path, const UsdReadOptions& opt = {});

// ============================================================================
// ArduPilot DataFlash (.bin, docs/ardupilot.md): self-describing records, each
// 0xA3 0x95, a type byte and a payload whose layout an FMT record (type 128)
// defines; FMTU, UNIT and MULT give the columns' units and multipliers.
// Little endian.
// ============================================================================

/// One message type as its FMT record defines it, with the units and
/// multipliers of its columns from FMTU (UNIT and MULT resolve their ids).
struct DataFlashFormat {
  std::uint8_t type = 0;
  std::size_t length = 0;  // bytes of a whole record, the 3 header bytes included
  std::string name;        // "IMU", "ATT", ...
  std::string format;      // one format character per column ("QBffffff...")
  std::vector<std::string> columns;
  std::vector<std::string> units;        // per column: UNIT's label ("deg", "m/s"), "" when not given
  std::vector<double> multipliers;       // per column: MULT's value, NaN when not given
  std::vector<std::size_t> offsets;      // per column, byte offset in the payload
  /// Index of a column; -1 when absent.
  int column(std::string_view name) const;
};

/// Size in bytes of a DataFlash format character (b B h H i I f d n N Z c C
/// e E L M q Q a); 0 for a character ArduPilot does not define.
int dataflash_type_size(char c);

/// Every record of one type, payloads (length - 3 bytes each) in file order.
struct DataFlashMessages {
  DataFlashFormat format;  // a copy of the log's definition (units resolved)
  std::vector<std::uint8_t> data;
  std::size_t count() const;
  /// A numeric column of every record, as ArduPilot's tools read it: integers
  /// as they are, c C e E divided by 100, L (latitude, longitude) times 1e-7
  /// degrees; InputError naming the message and column when it is absent or
  /// not a number (n N Z text, a int16[32]).
  Eigen::VectorXd column(std::string_view name) const;
  /// A text column (n N Z) of record i, trailing NULs removed.
  std::string text(std::string_view name, std::size_t i) const;
  /// TimeUS of every record (the first column, when it is TimeUS).
  std::vector<std::uint64_t> time_us() const;
};

struct DataFlashParameter {
  std::uint64_t time_us = 0;
  std::string name;
  double value = 0.0;
};

struct DataFlashLog {
  std::size_t bytes = 0;
  /// Bytes skipped to find the next record (corrupt bytes, records of a type
  /// no FMT defines), and where the first such run began (bytes when none).
  std::size_t skipped_bytes = 0, first_skip_offset = 0;
  std::size_t resyncs = 0;  // runs of skipped bytes
  /// Bytes after the last complete record (a file cut mid-record) and where
  /// that record began.
  std::size_t trailing_bytes = 0, trailing_offset = 0;
  std::map<std::uint8_t, DataFlashFormat> formats;       // by type id
  std::map<std::uint8_t, DataFlashMessages> messages;    // by type id, only types with records
  std::vector<DataFlashParameter> parameters;            // PARM records in file order
  /// Problems met and read past (an FMT whose length disagrees with its
  /// format), each naming its byte offset.
  std::vector<std::string> problems;
  const DataFlashMessages* find(std::string_view name) const;
  /// The last value a PARM record logged for `name`.
  std::optional<double> parameter(std::string_view name) const;
};

/// True when the bytes start with a DataFlash record header 0xA3 0x95.
bool is_dataflash(std::span<const std::uint8_t> head);
/// Parses a DataFlash log held in memory; `source` names it in messages. An
/// InputError when the bytes hold no FMT record (not a DataFlash log);
/// corrupt bytes and a cut last record are read past and counted.
DataFlashLog parse_dataflash(std::span<const std::uint8_t> bytes, const std::string& source);
DataFlashLog read_dataflash(const std::filesystem::path& path);

/// Builds a DataFlash file in memory, for tests: FMT records as defined,
/// data records packed from numbers (and text for n N Z).
class DataFlashWriter {
 public:
  DataFlashWriter();
  /// Defines a type: its FMT record (and, when units are given, its FMTU
  /// with UNIT records for the labels used). format as ArduPilot's
  /// ("QBfff"), columns comma-separated; units one label per column ("" none).
  void define(std::uint8_t type, std::string_view name, std::string_view format, std::string_view columns,
              const std::vector<std::string>& units = {});
  /// A record of a defined type: one number per numeric column, texts in
  /// order for the n N Z columns.
  void record(std::uint8_t type, const std::vector<double>& numbers, const std::vector<std::string>& texts = {});
  void parameter(std::uint64_t time_us, std::string_view name, float value);
  /// Raw bytes (corruption, for tests).
  void raw(std::string_view bytes);
  const std::string& bytes() const { return out_; }

 private:
  std::string out_;
  std::map<std::uint8_t, std::pair<std::string, std::size_t>> defined_;  // format, record length
  std::map<std::string, char> unit_ids_;
};

// ============================================================================
// ArduPilot's copter conventions (docs/ardupilot.md), read from a DataFlash log
// ============================================================================

/// The output channel of each motor: SERVOn_FUNCTION = 32 + k makes channel n
/// motor k (Motor1 = 33 .. Motor8 = 40; SRV_Channel.h). Without any such
/// parameter, channel k is motor k (ArduPilot's default layout) and
/// `from_parameters` is false.
struct ArduPilotMotors {
  std::vector<int> channel;  // [k - 1] = output channel (1-based, RCOU.Cn) of motor k
  bool from_parameters = false;
};
ArduPilotMotors ardupilot_motors(const DataFlashLog& log);

/// ArduPilot's thrust model of a motor output (AP_MotorsMulticopter): the
/// pulse width p maps to the actuator a = (p - MOT_PWM_MIN) / (MOT_PWM_MAX -
/// MOT_PWM_MIN), the throttle t = (a - MOT_SPIN_MIN) / (MOT_SPIN_MAX -
/// MOT_SPIN_MIN) clamped to 0..1, the battery-scaled throttle r = t V / V_ref,
/// and the thrust as a fraction of full thrust at V_ref, c = (1 - e) r + e r^2,
/// e = MOT_THST_EXPO. `c` is what quadid's rotor input "command" takes.
struct ArduPilotThrustCurve {
  double pwm_min = 1000.0, pwm_max = 2000.0;  // us, MOT_PWM_MIN/MAX (0 there, ArduCopter <= 4.2: RC3_MIN/MAX)
  double spin_min = 0.15, spin_max = 0.95;    // MOT_SPIN_MIN/MAX (ArduPilot's defaults)
  double expo = 0.65;                         // MOT_THST_EXPO
  /// The parameters the log holds, ArduPilot's defaults for those it does not
  /// (named in `defaulted`). InputError naming the parameter when out of its range.
  static ArduPilotThrustCurve from_log(const DataFlashLog& log, std::vector<std::string>* defaulted = nullptr);
  /// c of a pulse width (us) at the voltage ratio V / V_ref; 0 below the spin range.
  double thrust_of_pwm(double pwm, double voltage_ratio = 1.0) const;
  /// The pulse width of thrust fraction c (0..1) at voltage ratio V / V_ref: the inverse above the spin range.
  double pwm_of_thrust(double c, double voltage_ratio = 1.0) const;
};

/// A quadrotor's layout from FRAME_CLASS = 1 (quad) and FRAME_TYPE (0 plus,
/// 1 X; AP_MotorsMatrix): per motor k, its arm's direction (degrees from
/// forward, positive towards the right, as ArduPilot gives them) and its spin
/// (-1 counter-clockwise, +1 clockwise seen from above, as quadid's spin).
/// Empty when the log has no FRAME_CLASS / FRAME_TYPE or another frame.
struct ArduPilotFrame {
  std::string name;                // "quad X", "quad +"
  std::vector<double> angle_deg;   // per motor, from forward, clockwise seen from above
  std::vector<int> spin;           // per motor
};
std::optional<ArduPilotFrame> ardupilot_frame(const DataFlashLog& log);

/// A flight log (docs/file-formats.md columns, z up / FLU) as an ArduCopter
/// DataFlash log: IMU (GyrX..Z rad/s and AccX..Z m/s^2, body FRD; the specific
/// force from ax_b ay_b az_b (body FLU) when the log has them, else from the motion), ATT
/// (Roll Pitch Yaw, centidegrees, FRD -> NED), XKF1 (PN PE PD, VN VE VD: NED),
/// RCOU (C1..C14 pulse widths, from `command_columns` through `curve`, motor k
/// on channel k), ESC (RPM per instance, from `rpm_columns`), BAT (Volt), and
/// the PARM records of the curve, FRAME_CLASS/TYPE, SERVOn_FUNCTION and
/// LOG_BITMASK. Every record at every row of the log (full-rate logging).
struct ArduPilotWriteOptions {
  std::vector<std::string> command_columns;  // normalised thrust commands c (0..1) in motor order
  std::vector<std::string> rpm_columns;      // rotor speeds, rev/min, in motor order
  ArduPilotThrustCurve curve;
  double battery_voltage = 16.8;  // V, BAT.Volt and MOT_BAT_VOLT_MAX (no compensation sag)
  int frame_type = 1;             // FRAME_TYPE: 1 X, 0 plus
  /// LOG_BITMASK as written: ArduCopter's default 176126 with bits 0 ATTITUDE_FAST and 18 IMU_FAST.
  std::int32_t log_bitmask = 438271;
  /// Each message at every n-th row of the flight log (1 = every row, full
  /// rate). ArduCopter's default logging of a 400 Hz loop: ATT, XKF1, RCOU
  /// and BAT at 10 Hz, IMU at 25 Hz; with ATTITUDE_FAST and IMU_FAST: ATT and
  /// IMU at the loop rate, XKF1 at 25 Hz, RCOU still 10 Hz.
  int every_imu = 1, every_att = 1, every_ekf = 1, every_rcou = 1, every_esc = 1, every_bat = 1;
  std::uint64_t start_time_us = 1'000'000;
};
std::string ardupilot_log_from_flight_log(const FlightLog& log, const ArduPilotWriteOptions& opt = {});

// ============================================================================
// What a log holds (quadid log-info)
// ============================================================================

/// Gaps in a time series: intervals longer than `factor` x its median period.
struct TimeGap {
  double t = 0.0;         // s, log clock, the last sample before the gap
  double duration = 0.0;  // s
};
std::vector<TimeGap> find_gaps(const std::vector<double>& t, double factor);

/// The ULog listing in pyulog's layout (ulog_info, then parameters, then
/// ulog_messages): `verbose` as ulog_info -v (perf_ info, multi-info values).
std::string format_ulog_info(const ULog& log, bool verbose);
nlohmann::ordered_json ulog_info_json(const ULog& log);
/// Messages with counts, instances, rates and their columns' units; the
/// parameters' last values (`verbose`: also those logged again with another value).
std::string format_dataflash_info(const DataFlashLog& log, bool verbose);
nlohmann::ordered_json dataflash_info_json(const DataFlashLog& log);
/// Events with their variables, record counts, mean rates and gaps.
std::string format_usd_info(const UsdLog& log);
nlohmann::ordered_json usd_info_json(const UsdLog& log);

// ============================================================================
// Import: autopilot log -> flight log (docs/file-formats.md columns t x y z phi theta psi p q r
// plus the per-rotor signals under the log's own names; no wrench columns).
// ============================================================================

enum class GapPolicy { Longest, Refuse };

struct ImportOptions {
  /// Output grid rate. 250 Hz: well above the identification's band (its
  /// pre-filter is 4 Hz, motor lags are >= 5 ms, i.e. <= 32 Hz), with room
  /// for the anti-aliasing filter's transition below Nyquist (125 Hz); both
  /// the uSD's ~507 Hz records and PX4's 100-400 Hz topics map onto it.
  double rate_hz = 250.0;
  /// Anti-aliasing: zero-phase Butterworth of this order at
  /// aa_fraction x rate_hz, applied to a topic that is faster than the grid.
  int aa_order = 4;
  double aa_fraction = 0.4;
  /// A topic gap up to this is bridged by linear interpolation; a longer one
  /// splits the log. 0.25 s: PX4 dropouts (tens of ms), the uSD records' one
  /// gap (10-80 ms) and the motion-capture stream's irregular gaps (up to
  /// ~0.21 s in the sample logs) are bridged; a straight line over a gap D
  /// misses a motion of acceleration a by at most a D^2 / 8 (1.6 cm for
  /// 2 m/s^2 and 0.25 s), and the gap is 1/4 of a period of the
  /// identification's 4 Hz pre-filter cutoff.
  double max_bridge_s = 0.25;
  /// A gap is an interval longer than this factor x the topic's median period.
  double gap_factor = 3.0;
  /// On a longer gap: keep the longest gap-free part, or refuse (InputError).
  GapPolicy on_gap = GapPolicy::Longest;
  // PX4 topics (multi id 0). Rates fall back to vehicle_attitude's
  // rollspeed/pitchspeed/yawspeed on old logs; motors: "auto" = actuator_motors,
  // else esc_status, else actuator_outputs; "none" = no rotor columns.
  std::string position_topic = "vehicle_local_position";
  std::string attitude_topic = "vehicle_attitude";
  std::string rates_topic = "vehicle_angular_velocity";
  std::string motors_topic = "auto";
  /// Crazyflie pose: "auto" (motion capture locSrv.* when logged, else the
  /// onboard estimate), "mocap" or "estimate".
  std::string crazyflie_pose = "auto";
  double g = 9.81;  // m/s^2, converts the uSD accelerometer (g) to m/s^2

  /// std::invalid_argument naming the option (CLI spelling) when bad.
  void validate() const;
};

struct ImportReport {
  std::string kind;                 // "ulog" or "usd"
  std::vector<std::string> sources; // "column <- topic.field (rate Hz)"
  double rate_hz = 0.0;
  double t0 = 0.0;                  // s, log clock of the first row (t = 0)
  double duration = 0.0;            // s, of the kept part
  std::vector<TimeGap> dropouts;    // ULog dropout messages
  struct Gap {
    std::string topic;
    TimeGap gap;
    bool bridged = true;
  };
  std::vector<Gap> gaps;
  std::vector<std::string> warnings;
  /// The file ended mid-record: where, in one sentence ("" = complete); also among the warnings.
  std::string truncated;
  /// Each imported column's source: its topic (or event) and that topic's
  /// median sample rate, Hz, before resampling (a topic logged at 10 Hz holds
  /// nothing above 5 Hz, whatever the grid's rate).
  struct Source {
    std::string topic;
    double rate_hz = 0.0;
    /// How to log this source faster, in the autopilot's own terms ("" = PX4's SDLOG_PROFILE).
    std::string faster = {};
  };
  std::map<std::string, Source> column_sources;
  std::string summary() const;  // human-readable, one line per item
};

/// The report as `quadid import --json` prints it (kind, rate_hz, t0_s,
/// duration_s, sources, warnings, truncated, gaps, dropouts).
nlohmann::ordered_json import_report_json(const ImportReport& rep);

FlightLog import_ulog(const ULog& log, const ImportOptions& opt = {}, ImportReport* report = nullptr);
FlightLog import_usd(const UsdLog& log, const ImportOptions& opt = {}, ImportReport* report = nullptr);
/// An ArduCopter log: p q r and ax_b ay_b az_b from IMU (instance 0; body FRD
/// -> FLU), phi theta psi from ATT, or ANG when it has more records (4.6's
/// loop-rate attitude; degrees, FRD -> NED), x y z from XKF1
/// (core 0; NED -> z up) or else POS (latitude, longitude, altitude about the
/// first fix), and per motor k (ardupilot_motors): motorK.pwm (RCOU, us),
/// motorK.command (its thrust fraction, ArduPilotThrustCurve, scaled by the
/// battery's voltage BAT.Volt against MOT_BAT_VOLT_MAX or its median),
/// motorK.rpm (ESC telemetry of motor k's channel), battery.voltage (V).
FlightLog import_dataflash(const DataFlashLog& log, const ImportOptions& opt = {}, ImportReport* report = nullptr);

enum class LogKind { Ulog, Usd, DataFlash, Csv };
/// The kind from the first bytes: ULog magic, 0xBC, 0xA3 0x95, else CSV.
LogKind detect_log_kind(const std::filesystem::path& path);

struct LoadOptions {
  CsvReadOptions csv;      // for a CSV log
  ImportOptions import;    // for an autopilot log
  ULogReadOptions ulog;
  /// A ULog or uSD file cut mid-record (a crash, a power loss) is read to its
  /// last complete record, with a warning naming the byte (ImportReport::truncated);
  /// false: an InputError. (ulog.allow_truncated also allows it.)
  bool allow_truncated = true;
  /// Imported logs: InputError naming the missing `csv.required` columns
  /// (an import has no wrench columns; a rotor model adds them).
  bool check_required = true;
};
/// The ULog motor topic (actuator_motors, esc_status or actuator_outputs) that
/// column names such as "esc_status.esc[0].esc_rpm" name, or "auto" when none
/// does; InputError when they name two.
std::string motors_topic_named(const std::vector<std::string>& names);
/// Any flight log: ULog and uSD are imported (ImportReport in *report), CSV is
/// read with read_flight_log. The kind is recognised by the first bytes. A ULog's
/// rotor topic, when ImportOptions::motors_topic is "auto", is the one that
/// `csv.required` or the targets of `csv.map` name (motors_topic_named).
FlightLog load_any_log(const std::filesystem::path& path, const LoadOptions& opt = {},
                       ImportReport* report = nullptr);

}  // namespace quadid::logs

namespace quadid {

// --- PX4's rotor model from its control-allocation parameters (docs/import.md) ---------

/// The rotor model PX4's CA_ROTOR* parameters describe (logs::px4_rotor_geometry):
/// input "command" on the columns actuator_motors.control[0..n-1] (motor n+1 = CA_ROTORn),
/// thrust_max = CA_ROTORn_CT (PX4's allocation is linear in the normalised thrust
/// setpoint u = actuator_motors.control: T = CT u in steady state; THR_MDL_FAC maps u
/// to the ESC signal after the log), torque_ratio = |CA_ROTORn_KM|, spin ccw for
/// KM > 0, positions CA_ROTORn_PX/PY/PZ in FLU, time_constant 0 (PX4 does not log
/// it). InputError naming the parameter when the rotors differ in CT or KM
/// magnitude by more than 1 % (one coefficient per model) or a rotor is tilted
/// more than 5 degrees from the body z axis.
RotorModel px4_rotor_model(const logs::RotorGeometry& g);
/// The other way: the CA_ROTOR* geometry of a rotor model that takes commands
/// (thrust axes along body z, CT = thrust_max, KM = torque_ratio), e.g. to write a
/// simulated flight as a PX4 ULog (logs::px4_ulog_from_flight_log). InputError
/// unless the input is "command".
logs::RotorGeometry px4_geometry(const RotorModel& m);
/// A vehicle known only from a ULog: px4_rotor_model(px4_rotor_geometry(log)) and a
/// rough nominal set (rough_nominal, filled in once the log's wrench is known;
/// until then a placeholder of 1 kg). `source` names the log.
Vehicle px4_vehicle(const logs::ULog& log, const std::string& source);

}  // namespace quadid
