# RealSense bridge for `lmhost track --camera` and the view: opens the first
# Intel RealSense D4xx with pyrealsense2 and writes its depth stream (Z16,
# 848 x 480 at 90 fps, 100 um depth units where the sensor allows) and its
# colour stream (RGB8, 848 x 480 at 30 fps) to stdout in the LMCOLOR1 format
# (host/src/sense/track/wire.rs); LMHOST_CAMERA_COLOUR=0 asks for depth
# only, in the LMDEPTH1 format:
#   header: b"LMDEPTH1" or b"LMCOLOR1", u32 width, u32 height,
#           f64 fx, fy, ppx, ppy, depth_scale
#   LMCOLOR1 adds: u32 width, u32 height, f64 fx, fy, ppx, ppy,
#           u32 distortion model, f64 coeffs[5], f64 rotation[9] (depth to
#           colour, column-major as librealsense gives it), f64 translation[3] (m)
#   frame:  f64 time stamp (s), width*height u16, row-major;
#   LMCOLOR1 adds u8 0, or u8 1 + f64 time stamp + width*height*3 RGB bytes
#   when a new colour frame came in the same frameset.
# Every failure is one line on stderr and exit status 3.
import os
import struct
import sys

W, H, FPS = 848, 480, 90
CW, CH, CFPS = 848, 480, 30
COLOUR = os.environ.get("LMHOST_CAMERA_COLOUR", "1") != "0"


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
if COLOUR:
    cfg.enable_stream(rs.stream.color, CW, CH, rs.format.rgb8, CFPS)
try:
    prof = pipe.start(cfg)
except RuntimeError as e:
    fail("no camera: cannot start the depth and colour streams (%s)" % e)
sensor = prof.get_device().first_depth_sensor()
try:
    if sensor.supports(rs.option.depth_units):
        sensor.set_option(rs.option.depth_units, 0.0001)
except RuntimeError:
    pass
scale = sensor.get_depth_scale()
dprof = prof.get_stream(rs.stream.depth).as_video_stream_profile()
i = dprof.get_intrinsics()
out = sys.stdout.buffer
magic = b"LMCOLOR1" if COLOUR else b"LMDEPTH1"
out.write(magic + struct.pack("<II5d", i.width, i.height, i.fx, i.fy, i.ppx, i.ppy, scale))
if COLOUR:
    cprof = prof.get_stream(rs.stream.color).as_video_stream_profile()
    c = cprof.get_intrinsics()
    ex = dprof.get_extrinsics_to(cprof)
    out.write(struct.pack("<II4dI", c.width, c.height, c.fx, c.fy, c.ppx, c.ppy, int(c.model)))
    out.write(struct.pack("<5d", *list(c.coeffs)[:5]))
    out.write(struct.pack("<9d", *ex.rotation))
    out.write(struct.pack("<3d", *ex.translation))
out.flush()
last_colour = None
try:
    while True:
        fs = pipe.wait_for_frames()
        d = fs.get_depth_frame()
        if not d:
            continue
        out.write(struct.pack("<d", d.get_timestamp() / 1000.0))
        out.write(bytes(d.get_data()))
        if COLOUR:
            col = fs.get_color_frame()
            if col and col.get_frame_number() != last_colour:
                last_colour = col.get_frame_number()
                out.write(b"\x01" + struct.pack("<d", col.get_timestamp() / 1000.0))
                out.write(bytes(col.get_data()))
            else:
                out.write(b"\x00")
        out.flush()
except (BrokenPipeError, KeyboardInterrupt):
    pass
finally:
    pipe.stop()
