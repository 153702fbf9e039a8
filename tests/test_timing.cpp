// Timing estimation (timing.hpp) and PX4's rotor model from CA_ROTOR* (vehicle.hpp)
// on simulated PX4 flights of a known vehicle (tests/px4_sim_log.hpp).
#include "quadid/extended.hpp"
#include "quadid/logs.hpp"
#include "quadid/timing.hpp"
#include "quadid/vehicle.hpp"

#include "px4_sim_log.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <span>

using namespace quadid;
using namespace quadid::testing;

namespace {

FlightLog imported(const std::string& bytes) {
  const std::span<const std::uint8_t> b(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
  return logs::import_ulog(logs::parse_ulog(b, "sim.ulg"));
}

ExtendedOptions search_options() {
  ExtendedOptions xo;
  xo.terms = ModelTerms::real_flight(true);
  xo.force_cutoff_hz = 4.0;
  xo.moment_cutoff_hz = 8.0;
  return xo;
}

}  // namespace

TEST(TimingProto, Prints) {
  const Vehicle v = px4_test_vehicle(0.03);
  Px4SimOptions o;
  o.rotor_offset = 0.010;
  o.gyro_offset = 0.005;
  auto t0 = std::chrono::steady_clock::now();
  const std::string bytes = px4_sim_ulog(v, o);
  const FlightLog raw = imported(bytes);
  auto t1 = std::chrono::steady_clock::now();
  const logs::ULog u = [&] {
    const std::span<const std::uint8_t> b(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
    return logs::parse_ulog(b, "sim.ulg");
  }();
  Vehicle pv = px4_vehicle(u, "sim.ulg");
  ExtendedOptions xo = search_options();
  auto t2 = std::chrono::steady_clock::now();
  const TimingEstimate est = estimate_timing(raw, pv.rotors, xo);
  auto t3 = std::chrono::steady_clock::now();
  std::printf("sim+ulog %.3f s, search %.3f s\n%s", std::chrono::duration<double>(t1 - t0).count(),
              std::chrono::duration<double>(t3 - t2).count(), format_timing(est).c_str());
  const FlightLog L = apply_timing(raw, pv.rotors, est);
  xo.reference = rough_nominal(L, pv.rotors, 9.81);
  const ExtendedResult r = identify_extended(L, xo);
  std::printf("%s\n", format_real_flight(r).c_str());
  TimingEstimate truth;
  truth.time_constant = 0.03;
  truth.gyro_offset = 0.005;
  truth.rotor_offset = 0.010;
  truth.gyro_offset_estimated = truth.rotor_offset_estimated = true;
  const ExtendedResult r2 = identify_extended(apply_timing(raw, pv.rotors, truth), xo);
  std::printf("TRUE TIMING\n%s\n", format_real_flight(r2).c_str());
  for (bool w : {false, true}) {
    TimingOptions to;
    ExtendedOptions x2 = search_options();
    x2.terms.weight_rows = w;
    auto a = std::chrono::steady_clock::now();
    const TimingEstimate e2 = estimate_timing(raw, pv.rotors, x2, to);
    auto b = std::chrono::steady_clock::now();
    std::printf("weight %d: %.3f s\n%s", w, std::chrono::duration<double>(b - a).count(), format_timing(e2).c_str());
  }
}

TEST(TimingProto, WriteFile) {
  Px4SimOptions o;
  o.rotor_offset = 0.010;
  o.gyro_offset = 0.005;
  const std::string bytes = px4_sim_ulog(px4_test_vehicle(0.03), o);
  std::ofstream("/tmp/px4_sim.ulg", std::ios::binary) << bytes;
}
