// Private to src/simulation: payload changes during a flight (SimulationOptions::payload_changes).
#pragma once

#include "quadid/simulation.hpp"

namespace quadid::detail {

/// Throws std::invalid_argument naming the field (payload_changes[1].dm) unless every change lies
/// in the flight (0, last sample], the times increase, the mass stays > 0, the payload is a real
/// body, and the vehicle's inertia stays physically possible after each change.
void validate_payload_changes(const SimulationOptions& opt);

/// The changes of one flight, applied in time order at the controller ticks.
///
/// The plant's state is that of the present centre of mass (eqs. 1-4 hold there). What is logged,
/// checked against the safety limits and seen by the sensors is the motion of the vehicle's
/// reference point, the rotors' geometric centre (where the motion-capture markers and the wrench
/// are), `com` away from it in the body frame: p_ref = p - R(eta) com, v_ref = v - omega x com
/// (body); attitude and body rates are those of every point of a rigid body. So the motion is
/// exact, not approximated: at a change the payload is taken to move with the vehicle (no impulse),
/// the reference point's motion is continuous, and the state jumps to the new centre of mass.
class PayloadSchedule {
 public:
  explicit PayloadSchedule(const SimulationOptions& opt);
  /// Applies every change due at time t (s): the plant's mass properties, and x moved to the new
  /// centre of mass (p += R dc, v += omega x dc, dc the body-frame shift of the centre of mass).
  void apply_due(double t, Plant& plant, State& x);
  /// x (centre of mass) as the state of the reference point.
  State at_reference(const State& x) const;
  /// The body-frame acceleration of the reference point from that of the centre of mass:
  /// v_ref_dot = v_dot - omega_dot x com (com is fixed in the body).
  Vec3 reference_acceleration(const Vec3& v_dot, const Vec3& omega_dot) const {
    return offset_ ? Vec3(v_dot - omega_dot.cross(now_.com)) : v_dot;
  }
  bool any() const { return !changes_.empty(); }

 private:
  const std::vector<PayloadChange>& changes_;
  size_t next_ = 0;
  MassProperties now_;
  bool offset_ = false;  // now_.com != 0
};

}  // namespace quadid::detail
