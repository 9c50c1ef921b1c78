#pragma once
// The camera channel of the hardware abstraction layer: one interface for every source of
// frames tscd can read (dataset folder, video file, V4L2/USB device, the simulated world, and
// later the Axis PTZ camera). A source is read from one thread (the daemon's camera thread).

#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "core/bubble/camera.h"
#include "core/bubble/surface.h"
#include "drivers/dataset/base_point_spacing.h"
#include "drivers/dataset/planar_pose.h"
#include "drivers/stop_signal.h"

namespace tsc {

/// A source failed: it could not be opened, it disappeared, or a frame could not be decoded.
/// The message names the source (path or device) and what went wrong. `recoverable()` says
/// whether reading again may succeed (a corrupt frame, a device that may come back).
class CameraError : public std::runtime_error {
 public:
  CameraError(const std::string& what, bool recoverable)
      : std::runtime_error(what), recoverable_(recoverable) {}
  bool recoverable() const { return recoverable_; }

 private:
  bool recoverable_;
};

/// One frame as the pipeline needs it.
struct CameraFrame {
  Observation observation;  ///< colour (+ depth), and the pan/tilt it was taken at
  int64_t utime = 0;        ///< capture time, microseconds since the epoch
  int64_t sequence = 0;     ///< frames delivered by this source so far, 0-based
  /// True when this view completes a base point; false while a PTZ sweep continues (tscd
  /// gathers the views of a sweep and the pipeline takes them together, Pipeline::Process).
  bool ends_base_point = true;
  /// Where the robot was at capture, when the source knows it (a simulated camera: its route's
  /// or its base's pose, without the camera's shake): tscd takes no base points while it stands
  /// still (BasePointMotion).
  std::optional<PlanarPose> pose;
};

class CameraSource {
 public:
  virtual ~CameraSource() = default;
  /// Blocks until the next frame. nullopt at the end of a finite source (folder, video).
  /// Paces delivery to the configured rate. Throws CameraError.
  virtual std::optional<CameraFrame> Next() = 0;
  /// Thread-safe: asks a Next() blocked in another thread (pacing to the frame rate, a
  /// reconnect backoff, a stream read) to return soon, and every later Next() to return at
  /// once: nullopt, or a recoverable CameraError when cut short mid-read. For stopping.
  virtual void Interrupt() { interrupted_.Raise(); }
  /// Intrinsics of the frames Next() returns.
  virtual const CameraIntrinsics& intrinsics() const = 0;
  /// "folder:/data/x", "video:/a.mp4", "device:/dev/video0", "sim:office/7/route 2" — for logs.
  virtual std::string name() const = 0;
  /// How far apart its base points are, with the evidence, when the source knows (a dataset
  /// folder's declaration); nullopt for a live camera, whose spacing follows its frame rate
  /// (docs/decisions.md, "Frame rate").
  virtual std::optional<BasePointSpacing> spacing() const { return std::nullopt; }
  /// How many of the frames camera.fps paces make one base point: a PTZ sweep whose views are
  /// taken one by one (the Axis camera) counts each; a source that delivers a whole sweep at
  /// once, or none, counts 1. A live camera's base points come fps / this a second.
  virtual int paced_frames_per_base_point() const { return 1; }
  /// Views one base point's bubble surface is filled from: a pan sweep's, else 1 (a forward
  /// camera, whose thresholds follow its lens: AdaptToLens).
  virtual int views_per_base_point() const { return 1; }
  /// True for a recording read unpaced (a folder, video or simulated route at fps 0): its
  /// frames wait for the pipeline rather than being dropped, so a replay processes every frame
  /// whatever the machine's speed. A live or paced source is false: the robot would rather see
  /// now than catch up on the past.
  virtual bool replays_every_frame() const { return false; }
  /// True for a camera mounted on the robot whose frames do not carry a pose (a USB or PTZ
  /// camera): tscd reads where it is from the motor base's odometry, when there is one. A
  /// recording (folder, video) does not move with the base.
  virtual bool rides_the_base() const { return false; }

 protected:
  /// Raised by Interrupt(); sources wait on it (Clock::WaitUntil(us, interrupted_)).
  StopSignal interrupted_;
};

}  // namespace tsc
