#pragma once
// Chooses and opens the camera source CameraOptions names (camera.* and sim.* of the
// configuration). Those are plain structs (camera_options.h); only this factory reads them, the
// sources take their own Options.

#include <memory>

#include "drivers/base/motor_base.h"
#include "drivers/base/sim_base.h"
#include "drivers/camera/axis_camera.h"
#include "drivers/camera/camera_options.h"
#include "drivers/camera/camera_source.h"
#include "drivers/camera/sim_camera.h"
#include "drivers/clock.h"

namespace tsc {

/// The source camera.source names: "sim" (SimCamera on the scripted route of sim.route, or
/// rendering from `base` when given), "folder" (FolderCamera on camera.path), "video"
/// (VideoCamera on camera.path), "device" (DeviceCamera on camera.path, "/dev/videoN" or "N"),
/// "axis" (AxisCamera on camera.axis_host:axis_port, password from camera.axis_password_file).
/// `sim_depth` renders depth with the simulated camera. `base` and `clock` must outlive the
/// camera. Throws CameraError(recoverable = false) whose message names the bad setting
/// (camera.source, camera.path, sim.*) or the file/device that cannot be opened.
std::unique_ptr<CameraSource> MakeCamera(const CameraOptions& camera, const SimOptions& sim,
                                         const MotorBase* base = nullptr, bool sim_depth = false,
                                         Clock& clock = Clock::System());

/// The simulated camera's options for camera.* and sim.*. Throws std::invalid_argument
/// naming the bad sim.* value.
SimCameraOptions ToSimCameraOptions(const CameraOptions& camera, const SimOptions& sim,
                                    bool depth = false);

/// The Axis camera's options for camera.*; reads the password file. Throws
/// CameraError(recoverable = false) naming camera.axis_* when the file cannot be used,
/// std::invalid_argument naming the bad value.
AxisCameraOptions ToAxisCameraOptions(const CameraOptions& camera);

/// A simulated base standing at the start of this robot's scripted route (sim.*), default
/// speed limits and watchdog. Throws std::invalid_argument naming the bad sim.* value.
SimBaseOptions ToSimBaseOptions(const SimOptions& sim);

}  // namespace tsc
