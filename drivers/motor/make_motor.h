#pragma once
// Chooses and opens the motor channel the daemon's settings name (motor.driver).

#include <memory>

#include "daemon/daemon_options.h"
#include "drivers/base/motor_base.h"
#include "drivers/motor/jaguar_drive.h"

namespace tsc {

/// The driver's options for motor.*; the odometry starts at the start of this robot's
/// scripted route when the simulated camera renders from the base (camera.source = sim,
/// sim.drive = commands), else at the origin. Throws std::invalid_argument naming the bad
/// value.
JaguarOptions ToJaguarOptions(const DaemonOptions& daemon);

/// "sim": a SimBase when camera.source = sim and sim.drive = commands, else nullptr (no motor
/// channel); "jaguar-v2": JaguarV2Base; "jaguar-ascii": JaguarAsciiBase. Throws
/// std::invalid_argument (bad settings) or MotorError (no socket).
std::unique_ptr<MotorBase> MakeMotor(const DaemonOptions& daemon);

}  // namespace tsc
