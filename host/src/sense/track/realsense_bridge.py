# RealSense bridge for `lmhost track --camera`: opens the first Intel
# RealSense D4xx with pyrealsense2 and writes its depth stream (Z16,
# 848 x 480 at 90 fps, 100 um depth units where the sensor allows) to
# stdout in the LMDEPTH1 format (host/src/sense/track/source.rs):
#   header: b"LMDEPTH1", u32 width, u32 height, f64 fx, fy, ppx, ppy, depth_scale
#   frame:  f64 time stamp (s), width*height u16, row-major
# Every failure is one line on stderr and exit status 3.
import struct
import sys

W, H, FPS = 848, 480, 90


def fail(msg):
    sys.stderr.write(msg + "\n")
    sys.exit(3)


try:
    import pyrealsense2 as rs
except ImportError:
    fail("no camera: the RealSense bridge needs the pyrealsense2 wheel (pip install pyrealsense2)")

if len(rs.context().query_devices()) == 0:
    fail("no camera: no RealSense device found")

pipe = rs.pipeline()
cfg = rs.config()
cfg.enable_stream(rs.stream.depth, W, H, rs.format.z16, FPS)
try:
    prof = pipe.start(cfg)
except RuntimeError as e:
    fail("no camera: cannot start the depth stream (%s)" % e)
sensor = prof.get_device().first_depth_sensor()
try:
    if sensor.supports(rs.option.depth_units):
        sensor.set_option(rs.option.depth_units, 0.0001)
except RuntimeError:
    pass
scale = sensor.get_depth_scale()
i = prof.get_stream(rs.stream.depth).as_video_stream_profile().get_intrinsics()
out = sys.stdout.buffer
out.write(b"LMDEPTH1" + struct.pack("<II5d", i.width, i.height, i.fx, i.fy, i.ppx, i.ppy, scale))
out.flush()
try:
    while True:
        d = pipe.wait_for_frames().get_depth_frame()
        out.write(struct.pack("<d", d.get_timestamp() / 1000.0))
        out.write(bytes(d.get_data()))
        out.flush()
except (BrokenPipeError, KeyboardInterrupt):
    pass
finally:
    pipe.stop()
