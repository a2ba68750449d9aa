#!/usr/bin/env python3
"""Writes frames.txt: exact-byte vectors for proto/SPEC.md, built from the
spec with Python's own CRC (zlib) and a separate COBS, independent of the
Rust code that the vectors check. Run: python3 gen_frames.py > frames.txt"""
import struct, zlib

VERSION = 7

def cobs(data):
    out, block = bytearray(), bytearray()
    for b in data:
        if b == 0:
            out += bytes([len(block) + 1]) + block
            block = bytearray()
        else:
            block.append(b)
            if len(block) == 254:
                out += b"\xff" + block
                block = bytearray()
    out += bytes([len(block) + 1]) + block
    return bytes(out)

def frame(msg_type, seq, payload, version=VERSION, crc_xor=0):
    body = struct.pack("<BBH", version, msg_type, seq) + payload
    decoded = body + struct.pack("<I", zlib.crc32(body) ^ crc_xor)
    return decoded, b"\x00" + cobs(decoded) + b"\x00"

def echo(req_type, seq, payload=b"", version=VERSION):
    """What a response carries before its payload (SPEC section 2,
    Binding): the request's type byte and its decoded frame's CRC-32."""
    decoded, _ = frame(req_type, seq, payload, version)
    return bytes([req_type]) + decoded[-4:]

def hexs(b):
    return " ".join(f"{x:02x}" for x in b)

records = []

def rec(name, msg_type, seq, fields, payload, **kw):
    error = kw.pop("error", None)
    expect = kw.pop("expect", None)
    decoded, wire = frame(msg_type, seq, payload, **kw)
    records.append((name, msg_type, seq, fields, decoded, wire, error, expect))

def raw(name, fields, wire, error):
    records.append((name, None, None, fields, None, wire, error, None))

xyz = lambda v: struct.pack("<3i", *v)

def begin(slot, steps, t, period, enc, enc_len, center, foci, speed, max_off, rig, intensity,
          flags=0):
    """BeginUpload (41 bytes); flags bit 0: a per-step intensity table follows."""
    return (struct.pack("<BHHIBI", slot, steps, t, period, enc, enc_len) + xyz(center)
            + bytes([foci]) + struct.pack("<III", speed, max_off, rig) + bytes([intensity, flags]))

def intensity(slot, offset, data):
    """Intensity: slot, offset (u16, the first step), one level per step."""
    return struct.pack("<BH", slot, offset) + bytes(data)

def rig_crc(points):
    """CRC-32 of a rig: its positions as 12-byte records, in order."""
    return zlib.crc32(b"".join(xyz(p) for p in points))

# The device records' rig: two transducers 10 mm apart.
DEV_RIG = [(-5000, 0, 0), (5000, 0, 0)]

def small_begin(slot, enc, enc_len, max_off=20000, rig=None, level=255, flags=0, foci=1):
    """The device records' upload: 2 steps x 2 transducers, 200 ms a step,
    one focus at (0, 0, 200) mm, 340 m/s, for DEV_RIG."""
    rig = rig_crc(DEV_RIG) if rig is None else rig
    return begin(slot, 2, 2, 200000, enc, enc_len, (0, 0, 200000), foci, 340000, max_off, rig,
                 level, flags)

# The host lease (SPEC section 2): Play.lease_ms within 100 ..= 60000.
DEFAULT_LEASE_MS = 1000

def play(slot, at, flags, steps=0, lease_ms=DEFAULT_LEASE_MS):
    """Play: slot, at, flags, steps (u32, 0 = until Stop), lease_ms (u16)."""
    return bytes([slot, at, flags]) + struct.pack("<IH", steps, lease_ms)

def status(state, slot, step, counters, corr, queued, reason, lease_ms=0, expiries=0, uptime=0):
    return (bytes([state, slot]) + struct.pack("<H6I", step, *counters) + xyz(corr)
            + bytes([queued, reason]) + struct.pack("<HII", lease_ms, expiries, uptime))

def self_test(outcome, n=0, mismatches=0, first=0, sent=0, got=0):
    """SelfTestResult: outcome (0 unsupported, 1 passed, 2 failed), bytes,
    mismatches, first_mismatch (u32 each), sent, got (u8 each)."""
    return bytes([outcome]) + struct.pack("<III", n, mismatches, first) + bytes([sent, got])

rec("get_info", 0x01, 0, "GetInfo", b"")
rec("info", 0x82, 0,
    "Info (echo: GetInfo seq 0) proto_version=7 fw_version=0.1.0 max_transducers=996 slot_bytes=487424 "
    "slots=32 timer_hz=1000000 min_dwell_us=100 max_chunk=1024 rig_transducers=996 "
    "rig_crc32=0x89abcdef library_free=300000 clock=Crystal(2)",
    echo(0x01, 0) + struct.pack("<B3BHIBIIHHIIB", 7, 0, 1, 0, 996, 487424, 32, 1000000, 100, 1024, 996,
                0x89ABCDEF, 300000, 2))
rec("info_no_rig", 0x82, 0,
    "Info (echo: GetInfo seq 0) proto_version=7 fw_version=1.2.3 max_transducers=249 slot_bytes=1000 "
    "slots=32 timer_hz=25000000 min_dwell_us=1000 max_chunk=512 rig_transducers=0 "
    "rig_crc32=0x00000000 library_free=1000 clock=InternalRc(1)",
    echo(0x01, 0) + struct.pack("<B3BHIBIIHHIIB", 7, 1, 2, 3, 249, 1000, 32, 25000000, 1000, 512, 0, 0, 1000, 1))
rec("begin_upload", 0x02, 1,
    "BeginUpload slot=0 steps=82 transducers=996 period_us=200000 encoding=Delta(1) "
    "encoded_len=22000 center_um=[0,30000,30000] foci_per_step=4 sound_speed_mm_s=343200 "
    "max_offset_um=20000 rig_crc32=0x89abcdef intensity=255 flags=0",
    begin(0, 82, 996, 200000, 1, 22000, (0, 30000, 30000), 4, 343200, 20000, 0x89ABCDEF, 255))
rec("begin_upload_raw", 0x02, 2,
    "BeginUpload slot=1 steps=1 transducers=1 period_us=1000 encoding=Raw(0) "
    "encoded_len=1 center_um=[-1,-2,-3] foci_per_step=1 sound_speed_mm_s=100000 (lowest accepted) "
    "max_offset_um=100000 (largest accepted) rig_crc32=0x00000001 intensity=128 flags=0",
    begin(1, 1, 1, 1000, 0, 1, (-1, -2, -3), 1, 100000, 100000, 1, 128))
rec("begin_upload_table", 0x02, 31,
    "BeginUpload slot=2 steps=82 transducers=996 period_us=200000 encoding=Raw(0) "
    "encoded_len=81672 center_um=[0,0,200000] foci_per_step=1 sound_speed_mm_s=340000 "
    "max_offset_um=20000 rig_crc32=0x89abcdef intensity=200 flags=intensity_table(1)",
    begin(2, 82, 996, 200000, 0, 82 * 996, (0, 0, 200000), 1, 340000, 20000, 0x89ABCDEF, 200,
          flags=1))
rec("begin_rig", 0x0A, 26, "BeginRig transducers=996 crc32=0x89abcdef",
    struct.pack("<HI", 996, 0x89ABCDEF))
rec("commit_rig", 0x0B, 27, "CommitRig", b"")
rec("geometry", 0x03, 3,
    "Geometry first=996 positions=[[-96520,-66040,0],[-86360,-66040,0]]",
    struct.pack("<H", 996) + xyz((-96520, -66040, 0)) + xyz((-86360, -66040, 0)))
rec("chunk", 0x04, 5, "Chunk slot=0 offset=1024 data=[00 01 02 ff 00]",
    struct.pack("<BI", 0, 1024) + bytes([0, 1, 2, 0xFF, 0]))
rec("chunk_long", 0x04, 6,
    "Chunk slot=1 offset=0 data=300 bytes, byte i = (i mod 255) + 1 (crosses a 254-byte COBS block)",
    struct.pack("<BI", 1, 0) + bytes((i % 255) + 1 for i in range(300)))
rec("intensity", 0x0E, 32, "Intensity slot=2 offset=80 data=[ff 80 00]",
    intensity(2, 80, [0xFF, 0x80, 0x00]))
rec("intensity_long", 0x0E, 33,
    "Intensity slot=0 offset=65535 data=1024 bytes, byte i = i mod 256 (MAX_CHUNK levels)",
    intensity(0, 65535, [i % 256 for i in range(1024)]))
rec("commit", 0x05, 8, "Commit slot=0 crc32=0xcbf43926", struct.pack("<BI", 0, 0xCBF43926))
rec("play_next_cycle", 0x06, 9, "Play slot=1 at=NextCycle(0) flags=0 steps=0 lease_ms=1000",
    play(1, 0, 0))
rec("play_immediate", 0x06, 10,
    "Play slot=0 at=Immediate(1) flags=0 steps=0 lease_ms=100 (shortest accepted)",
    play(0, 1, 0, lease_ms=100))
rec("play_steps", 0x06, 28,
    "Play slot=2 at=NextCycle(0) flags=untracked(1) steps=100000 lease_ms=60000 (longest accepted)",
    play(2, 0, 1, 100000, lease_ms=60000))
rec("stop", 0x07, 11, "Stop", b"")
rec("renew", 0x0C, 29, "Renew", b"")
rec("self_test", 0x0D, 30, "SelfTest", b"")
rec("centroid", 0x08, 12,
    "Centroid seq=42 pos_um=[-1500,30250,29800] present=true host_time_us=1234567890123",
    struct.pack("<I", 42) + xyz((-1500, 30250, 29800)) + b"\x01" + struct.pack("<Q", 1234567890123))
rec("centroid_absent", 0x08, 13,
    "Centroid seq=4294967295 pos_um=[0,0,0] present=false host_time_us=18446744073709551615",
    struct.pack("<I", 0xFFFFFFFF) + xyz((0, 0, 0)) + b"\x00" + struct.pack("<Q", 2**64 - 1))
rec("get_status", 0x09, 14, "GetStatus", b"")
def status_rec(name, seq, fields, *values):
    """A Status answering GetStatus `seq`: its echo, then `status(*values)`."""
    rec(name, 0x83, seq, f"Status (echo: GetStatus seq {seq}) {fields}",
        echo(0x09, seq) + status(*values))

status_rec("status", 14,
    "state=Playing(1) slot=1 step=17 cycles=300 missed_deadlines=0 last_centroid_seq=42 "
    "bad_frames=2 crc_errors=1 nacks=3 correction_um=[-1500,250,-200] queued_slot=0 "
    "mute_reason=None(0) lease_ms=1000 lease_expiries=2 uptime_ms=123456",
    1, 1, 17, (300, 0, 42, 2, 1, 3), (-1500, 250, -200), 0, 0, 1000, 2, 123456)
status_rec("status_idle", 15,
    "state=Idle(0) slot=none(0xff) step=0 cycles=0 missed_deadlines=0 last_centroid_seq=0 "
    "bad_frames=0 crc_errors=0 nacks=0 correction_um=[0,0,0] queued_slot=none(0xff) "
    "mute_reason=None(0) lease_ms=0 lease_expiries=0 uptime_ms=0",
    0, 0xFF, 0, (0, 0, 0, 0, 0, 0), (0, 0, 0), 0xFF, 0)
status_rec("status_muted", 15,
    "state=Muted(2) slot=0 step=3 cycles=1 missed_deadlines=0 last_centroid_seq=7 "
    "bad_frames=0 crc_errors=0 nacks=1 correction_um=[0,0,0] queued_slot=none(0xff) "
    "mute_reason=CentroidOutOfRange(4) lease_ms=60000 lease_expiries=0 "
    "uptime_ms=4294967295 (the last before it wraps)",
    2, 0, 3, (1, 0, 7, 0, 0, 1), (0, 0, 0), 0xFF, 4, 60000, 0, 0xFFFFFFFF)
status_rec("status_lease_expired", 16,
    "state=Stopped(3) slot=4 step=9 cycles=12 missed_deadlines=0 last_centroid_seq=0 "
    "bad_frames=0 crc_errors=0 nacks=0 correction_um=[0,0,0] queued_slot=none(0xff) "
    "mute_reason=LeaseExpired(6) lease_ms=1000 lease_expiries=4294967295 uptime_ms=60000",
    3, 4, 9, (12, 0, 0, 0, 0, 0), (0, 0, 0), 0xFF, 6, 1000, 0xFFFFFFFF, 60000)
rec("self_test_unsupported", 0x84, 30,
    "SelfTestResult (echo: SelfTest seq 30) outcome=Unsupported(0) (other fields 0)",
    echo(0x0D, 30) + self_test(0))
rec("self_test_passed", 0x84, 30, "SelfTestResult (echo: SelfTest seq 30) outcome=Passed(1) bytes=1024",
    echo(0x0D, 30) + self_test(1, 1024))
rec("self_test_failed", 0x84, 30,
    "SelfTestResult (echo: SelfTest seq 30) outcome=Failed(2) bytes=1024 mismatches=1020 "
    "first_mismatch=3 sent=0x03 got=0xff",
    echo(0x0D, 30) + self_test(2, 1024, 1020, 3, 0x03, 0xFF))
rec("ack", 0x80, 0xBEEF, "Ack (echo: Renew seq 48879)", echo(0x0C, 0xBEEF))
COMMIT = struct.pack("<BI", 0, 0xCBF43926)
rec("nack", 0x81, 16, "Nack (echo: Commit seq 16 slot=0 crc32=0xcbf43926) code=OutOfOrder(8)",
    echo(0x05, 16, COMMIT) + bytes([8]))
rec("nack_library_full", 0x81, 16,
    "Nack (echo: Commit seq 16 slot=0 crc32=0xcbf43926) code=LibraryFull(16)",
    echo(0x05, 16, COMMIT) + bytes([16]))
rec("nack_no_rig", 0x81, 16, "Nack (echo: Commit seq 16 slot=0 crc32=0xcbf43926) code=NoRig(17)",
    echo(0x05, 16, COMMIT) + bytes([17]))
rec("nack_rig_mismatch", 0x81, 16,
    "Nack (echo: Commit seq 16 slot=0 crc32=0xcbf43926) code=RigMismatch(18)",
    echo(0x05, 16, COMMIT) + bytes([18]))
rec("nack_unknown_code", 0x81, 17,
    "Nack (echo: type 0x42, unknown, seq 17, empty) code=Other(200) (a code this version does "
    "not know)",
    echo(0x42, 17) + bytes([200]))

# Bad frames: what a decoder must report.
rec("err_crc", 0x80, 18, "Ack (echo: Stop seq 18) with the CRC's lowest bit flipped",
    echo(0x07, 18), crc_xor=1, error="crc")
rec("err_unknown_type", 0x42, 19, "type 0x42 (unknown), empty payload, valid CRC", b"",
    error="unknown_type")
rec("err_bad_version", 0x01, 20, "GetInfo with version 6 (the previous one), valid CRC", b"",
    version=6,
    error="bad_version")
rec("err_malformed_play", 0x06, 21, "Play slot=0 at=2 (no such timing)", play(0, 2, 0),
    error="malformed")
rec("err_malformed_play_flags", 0x06, 21, "Play slot=0 at=0 flags=0x02 (unknown flag bit)",
    play(0, 0, 2), error="malformed")
rec("err_malformed_play_short", 0x06, 21, "Play with the 2-byte payload of version 1 (needs 9)",
    bytes([0, 0]), error="malformed")
rec("err_malformed_play_no_steps", 0x06, 21,
    "Play with the 3-byte payload of version 2, without steps (needs 9)",
    bytes([0, 0, 0]), error="malformed")
rec("err_malformed_play_no_lease", 0x06, 21,
    "Play with the 7-byte payload of versions 3 and 4, without lease_ms (needs 9)",
    play(0, 0, 0)[:7], error="malformed")
rec("err_malformed_renew", 0x0C, 21, "Renew with a 1-byte payload (needs 0)", b"\x00",
    error="malformed")
rec("err_malformed_len", 0x05, 22, "Commit with a 4-byte payload (needs 5)", bytes([0, 1, 2, 3]),
    error="malformed")
rec("err_malformed_bool", 0x08, 23, "Centroid with present=2",
    struct.pack("<I", 1) + xyz((0, 0, 0)) + b"\x02" + struct.pack("<Q", 0), error="malformed")
rec("err_malformed_begin_short", 0x02, 24,
    "BeginUpload with the 35-byte payload of version 2 that lacks rig_crc32 and intensity "
    "(needs 41)",
    begin(0, 1, 1, 1000, 0, 1, (0, 0, 0), 1, 340000, 1, 0, 255)[:35], error="malformed")
rec("err_malformed_begin_v5", 0x02, 24,
    "BeginUpload with the 40-byte payload of versions 3-5, without flags (needs 41)",
    begin(0, 1, 1, 1000, 0, 1, (0, 0, 0), 1, 340000, 1, 0, 255)[:40], error="malformed")
rec("err_malformed_begin_flags", 0x02, 24, "BeginUpload with flags=0x02 (unknown flag bit)",
    begin(0, 1, 1, 1000, 0, 1, (0, 0, 0), 1, 340000, 1, 0, 255, flags=2), error="malformed")
rec("err_malformed_intensity_empty", 0x0E, 24, "Intensity slot=0 offset=0 without levels",
    intensity(0, 0, []), error="malformed")
# A list of no elements (SPEC section 3, Lists): as Intensity's, Chunk's
# and Geometry's are malformed, never acked as no-ops.
rec("err_malformed_chunk_empty", 0x04, 7, "Chunk slot=0 offset=4294967295 data=[] (no bytes)",
    struct.pack("<BI", 0, 0xFFFFFFFF), error="malformed")
rec("err_malformed_geometry_empty", 0x03, 4, "Geometry first=0 positions=[] (no transducer)",
    struct.pack("<H", 0), error="malformed")
rec("err_malformed_intensity_long", 0x0E, 24, "Intensity slot=0 offset=0 with 1025 levels",
    intensity(0, 0, [1] * 1025), error="malformed")
rec("err_malformed_geometry_v2", 0x03, 24,
    "Geometry with the version 2 slot byte before first (2 + 12n bytes needed, got 3 + 12)",
    struct.pack("<BH", 0, 0) + xyz((1, 2, 3)), error="malformed")
rec("err_malformed_commit_rig", 0x0B, 24, "CommitRig with a 1-byte payload (needs 0)", b"\x00",
    error="malformed")
rec("err_malformed_status_reason", 0x83, 25, "Status with mute_reason=7 (no such reason)",
    echo(0x09, 25) + status(2, 0, 0, (0, 0, 0, 0, 0, 0), (0, 0, 0), 0xFF, 7), error="malformed")
rec("err_malformed_status_v4", 0x83, 25,
    "Status with the 42-byte payload of version 4, without the lease fields (needs 52)",
    echo(0x09, 25) + status(0, 0xFF, 0, (0, 0, 0, 0, 0, 0), (0, 0, 0), 0xFF, 0)[:42],
    error="malformed")
rec("err_malformed_status_v6", 0x83, 25,
    "Status with the 48-byte payload of version 6, without uptime_ms (needs 52)",
    echo(0x09, 25) + status(0, 0xFF, 0, (0, 0, 0, 0, 0, 0), (0, 0, 0), 0xFF, 0)[:48],
    error="malformed")
rec("err_malformed_status_no_echo", 0x83, 25,
    "Status without the echo of its request (a whole status, but 5 bytes short of 57)",
    status(0, 0xFF, 0, (0, 0, 0, 0, 0, 0), (0, 0, 0), 0xFF, 0), error="malformed")
rec("err_malformed_ack_v6", 0x80, 25, "Ack without the echo of its request (version 6's empty Ack)",
    b"", error="malformed")
rec("err_malformed_nack_short_echo", 0x81, 25,
    "Nack with 4 bytes, shorter than the echo of its request (5) and its code",
    echo(0x07, 25)[:4], error="malformed")
rec("err_malformed_self_test_outcome", 0x84, 25, "SelfTestResult with outcome=3 (no such outcome)",
    echo(0x0D, 25) + self_test(3), error="malformed")
rec("err_malformed_self_test_fields", 0x84, 25,
    "SelfTestResult outcome=Passed(1) bytes=1024 with mismatches=1 (passed has none)",
    echo(0x0D, 25) + self_test(1, 1024, 1), error="malformed")
raw("err_cobs", "block code 5 but the delimiter comes after 2 data bytes", bytes([0, 5, 1, 2, 0]),
    "cobs")
raw("err_too_short", "3 decoded bytes", b"\x00" + cobs(bytes([1, 1, 0])) + b"\x00", "too_short")

# Device behaviour (SPEC sections 2, 3): fed in file order, after the records
# above, to a fresh device (at least 32 slots, 996 transducers,
# min_dwell_us <= 1000, tracking required: the default, no rig, no self-test;
# no time passes, so no lease expires),
# each request gets the response in its `expect` line.
SMALL = [1, 2, 3, 4]
DEV_CRC = rig_crc(DEV_RIG)
rec("dev_begin_no_rig", 0x02, 96,
    "BeginUpload slot=1 steps=2 transducers=2 ... before any rig (refused: NoRig)",
    small_begin(1, 0, 4), expect="nack NoRig")
rec("dev_begin_rig", 0x0A, 97, f"BeginRig transducers=2 crc32=0x{DEV_CRC:08x}",
    struct.pack("<HI", 2, DEV_CRC), expect="ack")
rec("dev_commit_rig_early", 0x0B, 98, "CommitRig before every position arrived",
    b"", expect="nack Incomplete")
rec("dev_geometry", 0x03, 99, "Geometry first=0 positions=[[-5000,0,0],[5000,0,0]]",
    struct.pack("<H", 0) + b"".join(xyz(p) for p in DEV_RIG), expect="ack")
rec("dev_commit_rig", 0x0B, 100, "CommitRig (positions CRC matches BeginRig's)", b"",
    expect="ack")
rec("dev_geometry_empty", 0x03, 150,
    "Geometry first=2 positions=[] (no transducer, on the committed rig: malformed, not acked)",
    struct.pack("<H", 2), error="malformed", expect="nack Malformed")
rec("dev_begin_rig_same", 0x0A, 101,
    "the same BeginRig again (the device holds that rig: acked, nothing changes)",
    struct.pack("<HI", 2, DEV_CRC), expect="ack")
rec("dev_begin_rig_mismatch", 0x02, 102,
    "BeginUpload slot=1 ... rig_crc32=0x12345678 (not the device's rig: RigMismatch)",
    small_begin(1, 0, 4, rig=0x12345678), expect="nack RigMismatch")
rec("dev_begin", 0x02, 103,
    "BeginUpload slot=1 steps=2 transducers=2 period_us=200000 encoding=Raw(0) encoded_len=4 "
    "center_um=[0,0,200000] foci_per_step=1 sound_speed_mm_s=340000 max_offset_um=20000 "
    f"rig_crc32=0x{DEV_CRC:08x} intensity=200",
    small_begin(1, 0, 4, level=200), expect="ack")
rec("dev_chunk_a", 0x04, 202, "Chunk slot=1 offset=0 data=[01 02]",
    struct.pack("<BI", 1, 0) + bytes(SMALL[:2]), expect="ack")
rec("dev_chunk_b", 0x04, 203, "Chunk slot=1 offset=2 data=[03 04]",
    struct.pack("<BI", 1, 2) + bytes(SMALL[2:]), expect="ack")
rec("dev_chunk_empty", 0x04, 204,
    "Chunk slot=1 offset=4 data=[] (at the next offset, but no bytes: malformed, not acked)",
    struct.pack("<BI", 1, 4), error="malformed", expect="nack Malformed")
rec("dev_chunk_a_again", 0x04, 104,
    "Chunk slot=1 offset=0 data=[01 02] (an earlier chunk repeated: identical, acked)",
    struct.pack("<BI", 1, 0) + bytes(SMALL[:2]), expect="ack")
rec("dev_chunk_inner_again", 0x04, 105,
    "Chunk slot=1 offset=1 data=[02 03] (identical to received Raw bytes across two chunks)",
    struct.pack("<BI", 1, 1) + bytes(SMALL[1:3]), expect="ack")
rec("dev_chunk_conflict", 0x04, 106, "Chunk slot=1 offset=0 data=[09 09] (differs from received)",
    struct.pack("<BI", 1, 0) + bytes([9, 9]), expect="nack OutOfOrder")
rec("dev_commit", 0x05, 107, f"Commit slot=1 crc32=0x{zlib.crc32(bytes(SMALL)):08x}",
    struct.pack("<BI", 1, zlib.crc32(bytes(SMALL))), expect="ack")
rec("dev_commit_again", 0x05, 108, "the same Commit repeated (idempotent: acked again)",
    struct.pack("<BI", 1, zlib.crc32(bytes(SMALL))), expect="ack")
rec("dev_commit_other_crc", 0x05, 109, "Commit slot=1 crc32=0x00000000 (no upload in progress)",
    struct.pack("<BI", 1, 0), expect="nack NoUpload")
# A per-step intensity table (version 6): slot 2, the same phases, levels
# [ff 80]; the Commit CRC covers the phases, then the table.
TABLE = [0xFF, 0x80]
TABLE_CRC = zlib.crc32(bytes(SMALL) + bytes(TABLE))
rec("dev_intensity_no_table", 0x0E, 160,
    "Intensity slot=1 offset=0 data=[ff] (slot 1 is committed, no upload: NoUpload)",
    intensity(1, 0, [0xFF]), expect="nack NoUpload")
rec("dev_begin_table", 0x02, 161,
    "BeginUpload slot=2 steps=2 transducers=2 Raw encoded_len=4 intensity=200 "
    "flags=intensity_table(1)",
    small_begin(2, 0, 4, level=200, flags=1), expect="ack")
rec("dev_table_chunk", 0x04, 162, "Chunk slot=2 offset=0 data=[01 02 03 04]",
    struct.pack("<BI", 2, 0) + bytes(SMALL), expect="ack")
rec("dev_table_a", 0x0E, 163, "Intensity slot=2 offset=0 data=[ff]", intensity(2, 0, TABLE[:1]),
    expect="ack")
rec("dev_table_commit_early", 0x05, 164,
    f"Commit slot=2 crc32=0x{TABLE_CRC:08x} (step 1's level has not arrived: Incomplete)",
    struct.pack("<BI", 2, TABLE_CRC), expect="nack Incomplete")
rec("dev_table_gap", 0x0E, 165, "Intensity slot=2 offset=2 data=[10] (past the 2 steps)",
    intensity(2, 2, [0x10]), expect="nack OutOfRange")
rec("dev_table_b", 0x0E, 166, "Intensity slot=2 offset=1 data=[80]", intensity(2, 1, TABLE[1:]),
    expect="ack")
rec("dev_table_again", 0x0E, 167,
    "Intensity slot=2 offset=0 data=[ff 80] (identical to received levels: acked)",
    intensity(2, 0, TABLE), expect="ack")
rec("dev_table_conflict", 0x0E, 168, "Intensity slot=2 offset=1 data=[81] (differs: OutOfOrder)",
    intensity(2, 1, [0x81]), expect="nack OutOfOrder")
rec("dev_table_commit", 0x05, 169,
    f"Commit slot=2 crc32=0x{TABLE_CRC:08x} (CRC-32 of the phases, then the table)",
    struct.pack("<BI", 2, TABLE_CRC), expect="ack")
rec("dev_begin_no_table", 0x02, 170,
    "BeginUpload slot=3 steps=2 transducers=2 Raw encoded_len=4 flags=0",
    small_begin(3, 0, 4), expect="ack")
rec("dev_intensity_without_table", 0x0E, 171,
    "Intensity slot=3 offset=0 data=[ff] (the upload has no table: OutOfRange)",
    intensity(3, 0, [0xFF]), expect="nack OutOfRange")
for name, seq, fields, enc, enc_len, max_off in [
    ("dev_begin_delta_empty", 110,
     "BeginUpload slot=0 steps=2 transducers=2 Delta encoded_len=0 (impossible: out of range)",
     1, 0, 20000),
    ("dev_begin_raw_len", 111,
     "BeginUpload slot=0 steps=2 transducers=2 Raw encoded_len=3 (needs 4: out of range)",
     0, 3, 20000),
    ("dev_begin_no_work_volume", 112,
     "BeginUpload slot=0 steps=2 transducers=2 Raw encoded_len=4 max_offset_um=0 (out of range)",
     0, 4, 0),
    ("dev_begin_wide_work_volume", 113,
     "BeginUpload slot=0 ... max_offset_um=100001 (above 100 mm: out of range)",
     0, 4, 100001),
]:
    rec(name, 0x02, seq, fields, small_begin(0, enc, enc_len, max_off), expect="nack OutOfRange")
# foci_per_step within FOCI_PER_STEP (1 ..= 32, the host's most).
for name, seq, foci, why in [
    ("dev_begin_no_foci", 130, 0, "a step with no focus"),
    ("dev_begin_many_foci", 131, 33, "above the 32 a host plans"),
]:
    rec(name, 0x02, seq,
        f"BeginUpload slot=0 steps=2 transducers=2 Raw encoded_len=4 foci_per_step={foci} "
        f"({why}: out of range)",
        small_begin(0, 0, 4, foci=foci), expect="nack OutOfRange")
rec("dev_play_slot_31", 0x06, 140,
    "Play slot=31 at=Immediate(1) flags=0 steps=0 (a library entry never uploaded)",
    play(31, 1, 0), expect="nack NotCommitted")
rec("dev_play_slot_32", 0x06, 141, "Play slot=32 at=Immediate(1) flags=0 steps=0 (no such entry)",
    play(32, 1, 0), expect="nack BadSlot")
# Every request naming a slot: BadSlot first of all (SPEC section 3),
# 0xFF (NO_SLOT, the Status's "none") included.
for name, seq, t, payload, what in [
    ("dev_chunk_no_slot", 153, 0x04, struct.pack("<BI", 0xFF, 0) + b"\x01", "Chunk slot=255 offset=0 data=[01]"),
    ("dev_intensity_no_slot", 154, 0x0E, intensity(0xFF, 0, [1]), "Intensity slot=255 offset=0 data=[01]"),
    ("dev_commit_no_slot", 155, 0x05, struct.pack("<BI", 0xFF, 0), "Commit slot=255 crc32=0x00000000"),
    ("dev_begin_no_slot", 156, 0x02, small_begin(0xFF, 0, 4), "BeginUpload slot=255 steps=2 transducers=2 Raw encoded_len=4"),
]:
    rec(name, t, seq, f"{what} (0xFF is NO_SLOT: no such entry)", payload, expect="nack BadSlot")
rec("dev_play_lease_zero", 0x06, 142,
    "Play slot=1 at=Immediate(1) flags=0 steps=0 lease_ms=0 (no lease: out of range)",
    play(1, 1, 0, lease_ms=0), expect="nack OutOfRange")
rec("dev_play_lease_long", 0x06, 143,
    "Play slot=1 at=Immediate(1) flags=0 steps=0 lease_ms=60001 (above 60 s: out of range)",
    play(1, 1, 0, lease_ms=60001), expect="nack OutOfRange")
rec("dev_play_lease_short", 0x06, 144,
    "Play slot=1 at=Immediate(1) flags=0 steps=0 lease_ms=99 (below 100 ms: out of range)",
    play(1, 1, 0, lease_ms=99), expect="nack OutOfRange")
rec("dev_status_not_played", 0x09, 145, "GetStatus (the refused plays changed nothing: idle)",
    b"", expect="status Idle None")
rec("dev_self_test_idle", 0x0D, 146,
    "SelfTest while nothing plays (a device without a self-test: unsupported)",
    b"", expect="self_test Unsupported")
rec("dev_play_tracked", 0x06, 114,
    "Play slot=1 at=Immediate(1) flags=0 steps=0 lease_ms=1000", play(1, 1, 0),
    expect="ack")
rec("dev_renew", 0x0C, 147, "Renew while playing", b"", expect="ack")
rec("dev_self_test_busy", 0x0D, 148, "SelfTest while a slot plays (refused: Busy)", b"",
    expect="nack Busy")
rec("dev_status_waiting", 0x09, 115, "GetStatus (muted: waiting for tracking)", b"",
    expect="status Muted WaitingForTracking")
rec("dev_centroid_seq_zero", 0x08, 151,
    "Centroid seq=0 pos_um=[3000,-4000,200000] present=true (0 is the wire's 'none', "
    "last_centroid_seq's: never newer than anything, refused as OutOfOrder, changes nothing)",
    struct.pack("<I", 0) + xyz((3000, -4000, 200000)) + b"\x01" + struct.pack("<Q", 0),
    expect="nack OutOfOrder")
rec("dev_status_seq_zero", 0x09, 152, "GetStatus (still waiting for tracking)", b"",
    expect="status Muted WaitingForTracking")
rec("dev_centroid_in_range", 0x08, 116,
    "Centroid seq=1000 pos_um=[3000,-4000,200000] present=true (5 mm from the centre)",
    struct.pack("<I", 1000) + xyz((3000, -4000, 200000)) + b"\x01" + struct.pack("<Q", 0),
    expect="ack")
rec("dev_status_playing", 0x09, 117, "GetStatus (playing)", b"", expect="status Playing None")
rec("dev_centroid_out_of_range", 0x08, 118,
    "Centroid seq=1001 pos_um=[12000,16001,200000] present=true (20.0008 mm away: refused, mutes)",
    struct.pack("<I", 1001) + xyz((12000, 16001, 200000)) + b"\x01" + struct.pack("<Q", 0),
    expect="nack OutOfRange")
rec("dev_status_out_of_range", 0x09, 119, "GetStatus (muted: centroid out of range)", b"",
    expect="status Muted CentroidOutOfRange")
rec("dev_centroid_overflow", 0x08, 120,
    "Centroid seq=1002 pos_um=[-2147483648,2147483647,-2147483648] present=true",
    struct.pack("<I", 1002) + xyz((-2**31, 2**31 - 1, -2**31)) + b"\x01" + struct.pack("<Q", 0),
    expect="nack OutOfRange")
rec("dev_centroid_edge", 0x08, 121,
    "Centroid seq=1003 pos_um=[12000,16000,200000] present=true (exactly 20 mm: in range)",
    struct.pack("<I", 1003) + xyz((12000, 16000, 200000)) + b"\x01" + struct.pack("<Q", 0),
    expect="ack")
rec("dev_status_back", 0x09, 122, "GetStatus (playing again)", b"", expect="status Playing None")
rec("dev_play_untracked", 0x06, 123,
    "Play slot=1 at=Immediate(1) flags=untracked(1) steps=0 lease_ms=60000",
    play(1, 1, 1, lease_ms=60000), expect="ack")
rec("dev_centroid_absent", 0x08, 124, "Centroid seq=1004 pos_um=[0,0,0] present=false",
    struct.pack("<I", 1004) + xyz((0, 0, 0)) + b"\x00" + struct.pack("<Q", 0), expect="ack")
rec("dev_status_untracked", 0x09, 125, "GetStatus (untracked: plays without a finger)", b"",
    expect="status Playing None")
rec("dev_play_steps", 0x06, 128,
    "Play slot=1 at=Immediate(1) flags=untracked(1) steps=3 lease_ms=1000 "
    "(no time passes: still playing)",
    play(1, 1, 1, 3), expect="ack")
rec("dev_status_steps", 0x09, 129, "GetStatus (playing its 3 steps)", b"",
    expect="status Playing None")
rec("dev_stop", 0x07, 126, "Stop", b"", expect="ack")
rec("dev_status_stopped", 0x09, 127, "GetStatus (stopped)", b"", expect="status Stopped Stopped")
rec("dev_renew_stopped", 0x0C, 149, "Renew while nothing plays (acked, changes nothing)", b"",
    expect="ack")

print("""# lm-proto exact-byte test vectors (generated by gen_frames.py from SPEC.md,
# independently of the Rust encoder). Records are separated by blank lines;
# each line is "<key> <value>"; '#' starts a comment line.
#   name     unique name
#   type     message type byte (hex), absent for framing errors
#   seq      sequence number (decimal), absent for framing errors
#   fields   the message's fields, for humans
#   decoded  hex of the frame after COBS decoding (header, a response's
#            echo of its request, payload, CRC)
#   wire     hex of the on-wire bytes: 00, COBS(decoded), 00
#   error    absent for good frames; else what the decoder must report:
#            crc | unknown_type | bad_version | malformed | cobs | too_short
#   expect   device behaviour records only (names dev_*): the response of a
#            fresh device fed every record in file order: ack |
#            nack <NackCode> | status <DeviceState> <MuteReason> |
#            self_test <outcome> (Unsupported, Passed, Failed)
""")
for name, t, seq, fields, decoded, wire, error, expect in records:
    print(f"name {name}")
    if t is not None:
        print(f"type {t:02x}")
        print(f"seq {seq}")
    print(f"fields {fields}")
    if decoded is not None:
        print(f"decoded {hexs(decoded)}")
    print(f"wire {hexs(wire)}")
    if error:
        print(f"error {error}")
    if expect:
        print(f"expect {expect}")
    print()
