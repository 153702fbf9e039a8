// The 2 kg test vehicle shared by the vehicle tests: an X quadrotor with its
// centre of mass off the rotors' centre, products of inertia, rotor speeds in
// rad/s, a 30 ms motor lag and its own sensor table (unlike the built-in x500,
// whose tensor is diagonal and whose rotors sit symmetrically).
#pragma once

namespace quadid::testing {

inline constexpr const char* kHeavyVehicle = R"(name = "heavy-x"
[nominal]
m = 2.0
Ixx = 0.021
Iyy = 0.024
Izz = 0.040
Ixy = 0.0004
Ixz = -0.0003
Iyz = 0.0002
[rotors]
input = "speed"
columns = ["w1", "w2", "w3", "w4"]
kf = 1.2e-5
thrust_max = 13.0
torque_ratio = 0.016
time_constant = 0.03
positions = [[0.17, -0.18, 0.01], [-0.19, 0.17, 0.01], [0.17, 0.17, 0.01], [-0.19, -0.18, 0.01]]
spin = ["ccw", "ccw", "cw", "cw"]
[sensors]
gyro_noise = 0.002
)";

}  // namespace quadid::testing
