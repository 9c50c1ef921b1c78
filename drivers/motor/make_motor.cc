#include "drivers/motor/make_motor.h"

#include <stdexcept>

#include "drivers/base/sim_base.h"
#include "drivers/camera/make_camera.h"
#include "drivers/motor/jaguar_ascii_base.h"
#include "drivers/motor/jaguar_v2_base.h"

namespace tsc {
namespace {

bool CameraRidesBase(const CameraOptions& camera, const SimOptions& sim) {
  return camera.source == "sim" && sim.drive == "commands";
}

}  // namespace

JaguarOptions ToJaguarOptions(const MotorOptions& m, const CameraOptions& camera,
                              const SimOptions& sim) {
  JaguarOptions o;
  o.host = m.address;
  o.port = m.port;
  o.max_linear_mps = m.max_linear_mps;
  o.max_angular_radps = m.max_angular_radps;
  o.watchdog_s = m.watchdog_s;
  o.link_timeout_s = m.link_timeout_s;
  o.full_power_mps = m.full_power_mps;
  o.track_width_m = m.track_width_m;
  o.counts_per_metre = m.counts_per_metre;
  o.left_sign = m.left_sign;
  o.right_sign = m.right_sign;
  o.forward_sign = m.forward_sign;
  o.turn_sign = m.turn_sign;
  if (CameraRidesBase(camera, sim)) {
    const SimBaseOptions start = ToSimBaseOptions(sim);
    o.start_x_m = start.start_x_m;
    o.start_y_m = start.start_y_m;
    o.start_heading_rad = start.start_heading_rad;
  }
  o.Validate();
  return o;
}

std::unique_ptr<MotorBase> MakeMotor(const MotorOptions& motor, const CameraOptions& camera,
                                     const SimOptions& sim) {
  if (motor.driver == "sim") {
    if (!CameraRidesBase(camera, sim)) return nullptr;
    SimBaseOptions o = ToSimBaseOptions(sim);
    o.max_linear_mps = motor.max_linear_mps;
    o.max_angular_radps = motor.max_angular_radps;
    o.watchdog_s = motor.watchdog_s;
    return std::make_unique<SimBase>(o);
  }
  if (motor.driver == "jaguar-v2") {
    return std::make_unique<JaguarV2Base>(ToJaguarOptions(motor, camera, sim));
  }
  if (motor.driver == "jaguar-ascii") {
    return std::make_unique<JaguarAsciiBase>(ToJaguarOptions(motor, camera, sim));
  }
  throw std::invalid_argument("motor.driver: '" + motor.driver +
                              "' is not one of sim | jaguar-v2 | jaguar-ascii");
}

}  // namespace tsc
