#!/usr/bin/env python3
"""Writes test/fuzz/seeds: valid inputs the fuzz targets start from (and ctest replays).

Uses lcm-gen's Python types of lcmtypes/ (generated into a temporary folder; no LCM Python
module needed). Run from anywhere: python3 test/fuzz/make_seeds.py
"""
import math
import os
import struct
import subprocess
import sys
import tempfile

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.dirname(os.path.dirname(here))
gen = tempfile.mkdtemp()
types = sorted(os.path.join(root, "lcmtypes", f) for f in os.listdir(os.path.join(root, "lcmtypes")) if f.endswith(".lcm"))
subprocess.run(["lcm-gen", "-p", "--ppath", gen] + types, check=True)
sys.path.insert(0, gen)
from depowder import (depth_image_t, nozzle_plan_t, part_pose_t, point_cloud_t, pose_t,  # noqa: E402
                      progress_t, robot_state_t, waypoint_t)


def pose(xyz, wxyz=(1, 0, 0, 0)):
    p = pose_t()
    p.position, p.orientation = list(xyz), list(wxyz)
    return p


def write(kind, name, data):
    os.makedirs(os.path.join(here, "seeds", kind), exist_ok=True)
    with open(os.path.join(here, "seeds", kind, name), "wb") as f:
        f.write(data)


# An 8 x 6 depth frame from 1 m above, looking down, 0.80 to 0.81 m away.
d = depth_image_t()
d.utime, d.frame, d.camera, d.width, d.height = 1, 0, "LEFT", 8, 6
d.fx = d.fy = 5.0
d.cx, d.cy, d.min_range, d.max_range = 3.5, 2.5, 0.1, 3.0
d.T_cell_camera = pose((0, 0, 1.0), (0, 1, 0, 0))
d.depth_unit, d.data = 0.00025, struct.pack("<48H", *range(3200, 3248))
d.num_bytes = len(d.data)
# A 21 x 21 grid of points 1 cm apart at z = 2 cm, from both cameras.
c = point_cloud_t()
c.utime, c.seq, c.frame, c.origin, c.resolution = 1000, 0, "cell", [0, 0, 0.02], 0.0005
c.xyz = [[i * 10, j * 10, 0] for i in range(-20, 21, 2) for j in range(-20, 21, 2)]
c.num_points, c.num_sources, c.sources, c.source_utimes = len(c.xyz), 2, ["LEFT", "RIGHT"], [1000, 1000]
pp = part_pose_t()
pp.utime, pp.part, pp.method, pp.status, pp.status_reason = 1000, "cube", "cu", 1, ""
pp.T_cell_part, pp.eta, pp.fitness, pp.inlier_ratio, pp.iterations, pp.compute_ms = pose((0, 0, 0.03)), 0.6, 0.001, 0.9, 5, 1.0
pp.template_updated, pp.template_version, pp.template_resolution = True, 1, 0.0005
pp.template_size, pp.template_xyz = 2, [[1, 2, 3], [4, 5, 6]]
rs = robot_state_t()
rs.utime, rs.mode, rs.mode_reason, rs.measured, rs.q, rs.qd = 1000, 0, "", True, [0, 0, 1.57, 0, 1.57, 0], [0] * 6
rs.T_cell_nozzle, rs.tool, rs.plan_id, rs.waypoint_index, rs.plan_utime = pose((0, 0, 0.4)), 0, -1, 0, 0
pr = progress_t()
pr.utime, pr.part, pr.phase, pr.status, pr.status_reason = 1000, "cube", 2, 0, ""
pr.eta, pr.eta_raw, pr.h_pow, pr.h_max, pr.h_min, pr.T_cell_part = 0.6, 0.6, 0.04, 0.06, 0.0, pose((0, 0, 0.03))
# The contour (Eq. 2): eight points 5 cm round the cube at the powder's height. A PROGRESS that
# says OK needs three at least, or the planner refuses it and plans nothing.
pr.contour = [[round(0.05 * math.cos(k * math.pi / 4), 4), round(0.05 * math.sin(k * math.pi / 4), 4), 0.04]
              for k in range(8)]
pr.num_contour, pr.num_band, pr.band = len(pr.contour), 0, []

# fuzz_lcm: [type byte][message], the type byte as fuzz_lcm.cpp's table orders them.
for kind, name, msg in [(0, "point_cloud", c), (1, "depth_image", d), (2, "part_pose", pp), (4, "robot_state", rs),
                        (5, "progress", pr)]:
    write("lcm", name, bytes([kind]) + msg.encode())

# fuzz_nodes: records [kind][length, 2 bytes LE][message].
def record(kind, msg):
    b = msg.encode()
    return bytes([kind]) + struct.pack("<H", len(b)) + b


pp.template_updated, pp.template_size, pp.template_xyz = False, 0, []
write("nodes", "robot_pose_progress_points", record(3, rs) + record(1, pp) + record(2, pr) + record(0, c) + record(0, c))

# fuzz_camera: the same records, kind 0 a depth frame, 1 a robot state: a robot state, then a
# time step of LEFT and RIGHT with its own, twice; the nozzle's tube runs through one of the
# frame's points, so the self-filter takes it.
rs.T_cell_nozzle = pose((0.08, 0.08, 0.15), (0, 1, 0, 0))  # spraying down
r = depth_image_t.decode(d.encode())
r.camera = "RIGHT"
camera = record(1, rs)
for t in (1000, 34000):
    d.utime = r.utime = rs.utime = t
    camera += record(1, rs) + record(0, d) + record(0, r)
write("camera", "state_left_right", camera)


# fuzz_plan: records [cycles, 2 bytes LE][length, 2 bytes LE][nozzle_plan_t]; length 0 stops.
def plan(plan_id, points, speed, tool):
    m = nozzle_plan_t()
    m.utime, m.plan_id, m.part, m.phase, m.reason = 1000, plan_id, "cube", 2, "contour"
    m.waypoints = []
    for xyz in points:
        w = waypoint_t()
        w.T_cell_nozzle, w.tool, w.speed, w.q = pose(xyz, (0, 1, 0, 0)), tool, speed, [0] * 6  # nozzle z down
        m.waypoints.append(w)
    m.num_waypoints = len(m.waypoints)
    return m.encode()


def step(cycles, data):
    return struct.pack("<HH", cycles, len(data)) + data


square = [(0.05, 0.05, 0.15), (-0.05, 0.05, 0.12), (-0.05, -0.05, 0.12), (0.05, -0.05, 0.15)]
line = [(0.0, 0.0, 0.30), (0.1, 0.0, 0.2)]
write("plan", "square_then_line", step(150, plan(1, square, 0.2, 1)) + step(60, plan(2, line, 0.25, 2)))
write("plan", "square_stopped", step(100, plan(1, square, 0.1, 1)) + step(50, b""))


# fuzz_log_time: records [0][8, 2 bytes LE][time delta, int64 LE] for an event and
# [1][17, 2 bytes LE][time delta][process byte][uptime delta, int64 LE] for a heartbeat. Two
# cameras at 30 Hz and two processes' heartbeats at 2 Hz for 8 s; the recording clock an hour
# back from 2 s to 4 s, and nothing at all from 5 s to 6.5 s.
sent = [(t * 33333 + cam * 100, None) for t in range(240) for cam in range(2)]
sent += [(t * 500000 + p * 170000, p) for t in range(16) for p in range(2)]
sent = sorted((e for e in sent if not 5000000 <= e[0] < 6500000), key=lambda e: e[0])
log_time, last, uptime = b"", 0, [0, 0]
for t, p in sent:
    rec = 1795000000000000 + t - (3600000000 if 2000000 <= t < 4000000 else 0)
    if p is None:
        log_time += struct.pack("<BHq", 0, 8, rec - last)
    else:
        log_time += struct.pack("<BHqBq", 1, 17, rec - last, p, t - uptime[p])
        uptime[p] = t
    last = rec
write("log_time", "steps_and_silence", log_time)


# fuzz_log_file: LCM logs as lcm-logger writes them (lcm/eventlog.c: big-endian sync word
# 0xEDA1DA01, event number, time, channel length, data length, channel, data): a whole one of a
# ROBOT_STATE and two POINTS, and one damaged as recordings are (bytes of another file after the
# first event, a header with a channel length beyond 999, the last event cut short).
def event(num, utime, channel, data):
    return struct.pack(">IqqII", 0xEDA1DA01, num, utime, len(channel), len(data)) + channel.encode() + data


state = robot_state_t()
state.utime, state.mode_reason, state.T_cell_nozzle = 1795000000000000, "", pose((0.1, 0.0, 0.3))
cloud = point_cloud_t()
cloud.utime, cloud.frame, cloud.num_points = 1795000000033333, "cell", 0
events = [event(0, 1795000000000100, "ROBOT_STATE", state.encode()),
          event(1, 1795000000033400, "POINTS", cloud.encode()),
          event(2, 1795000000066700, "POINTS", cloud.encode())]
write("log_file", "whole", b"".join(events))
bad = bytearray(events[1])
bad[20:24] = struct.pack(">I", 5000)
write("log_file", "damaged", events[0] + b"solid part\n" + bytes(bad) + events[2] + events[0][:-7])
