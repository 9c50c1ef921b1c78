#pragma once
// Chooses and opens the motor channel MotorOptions names (motor.driver).

#include <memory>

#include "drivers/base/motor_base.h"
#include "drivers/camera/camera_options.h"
#include "drivers/motor/jaguar_drive.h"
#include "drivers/motor/motor_options.h"

namespace tsc {

/// The driver's options for motor.*; the odometry starts at the start of this robot's
/// scripted route when the simulated camera renders from the base (camera.source = sim,
/// sim.drive = commands), else at the origin. Throws std::invalid_argument naming the bad
/// value.
JaguarOptions ToJaguarOptions(const MotorOptions& motor, const CameraOptions& camera,
                              const SimOptions& sim);

/// "sim": a SimBase when camera.source = sim and sim.drive = commands, else nullptr (no motor
/// channel); "jaguar-v2": JaguarV2Base; "jaguar-ascii": JaguarAsciiBase. Throws
/// std::invalid_argument (bad settings) or MotorError (no socket).
std::unique_ptr<MotorBase> MakeMotor(const MotorOptions& motor, const CameraOptions& camera,
                                     const SimOptions& sim);

}  // namespace tsc
