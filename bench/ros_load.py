#!/usr/bin/env python3
"""Load benchmark of the ROS nodes: 4 camera streams at 30 Hz into nerf_node and a 100 Hz wrench
stream into dem_node, for N minutes, reporting resident memory over time, NeRF training
iterations/s against a no-ingest baseline, dem_node solves and crashes.

The run alternates three phases of --phase-seconds each, so that the training's own drift in
speed (the occupancy grid prunes, samples per ray fall) hits every phase alike:
  idle     the camera players are stopped (SIGSTOP) and no wrench is sent: the baseline
  cameras  4 dataset_player nodes at 30 Hz each (Image + CameraInfo, rgba8)
  all      cameras + WrenchStamped at 100 Hz into dem_node (each re-solves, latest wins)

Run it with the devel space sourced (bench/ros_load.sh does that), e.g.
  bash bench/ros_load.sh /work/build-ros --minutes 2
It starts its own roscore on --port, so it does not disturb rostests or other masters.
"""
import argparse
import atexit
import json
import os
import signal
import subprocess
import sys
import threading
import time

import rospy
from dem_nerf.msg import TrainingStatus
from dem_nerf.srv import ExtractParticles
from geometry_msgs.msg import TransformStamped, WrenchStamped
from sensor_msgs.msg import PointCloud2
import tf2_ros

PHASES = ["idle", "cameras", "all"]


def rss_mib(pid):
    try:
        with open("/proc/%d/status" % pid) as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        return None
    return None


def cpu_seconds(pid):
    try:
        with open("/proc/%d/stat" % pid) as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except OSError:
        return None


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--build", required=True, help="catkin build folder (devel/ and bin/ inside)")
    parser.add_argument("--minutes", type=float, default=10.0, help="measured time after warm-up (default 10)")
    parser.add_argument("--phase-seconds", type=float, default=30.0)
    parser.add_argument("--warmup-seconds", type=float, default=25.0, help="training before measuring")
    parser.add_argument("--size", type=int, default=200, help="image size of the synthetic cuboid")
    parser.add_argument("--solver", default="dem", choices=["dem", "fem"], help="dem_node's solver")
    parser.add_argument("--spacing", type=float, default=0.015, help="particle spacing (m) for dem_node")
    parser.add_argument("--port", type=int, default=11357, help="port of the benchmark's own roscore")
    parser.add_argument("--out", default="/tmp/dem_nerf_ros_load", help="folder for data, logs and results")
    args = parser.parse_args()

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    devel_lib = os.path.join(args.build, "devel", "lib", "dem_nerf")
    os.makedirs(args.out, exist_ok=True)
    data = os.path.join(args.out, "cuboid_%d" % args.size)
    if not os.path.exists(os.path.join(data, "transforms_train.json")):
        subprocess.run([os.path.join(args.build, "bin", "demnerf"), "synth", "--scene", "cuboid", "--views", "24",
                        "--test-views", "4", "--size", str(args.size), "--out", data], check=True,
                       stdout=subprocess.DEVNULL)
    env = dict(os.environ, ROS_MASTER_URI="http://localhost:%d" % args.port, ROS_HOME=args.out)
    os.environ.update(env)
    logs = []

    def start(name, command):
        log = open(os.path.join(args.out, name + ".log"), "w")
        logs.append(log)
        return subprocess.Popen(command, env=env, stdout=log, stderr=subprocess.STDOUT)

    processes = {"roscore": start("roscore", ["roscore", "-p", str(args.port)])}

    def leave_nothing_running():  # after an error or Ctrl-C; a normal end has stopped them already
        for process in processes.values():
            if process.poll() is None:
                process.send_signal(signal.SIGCONT)
                process.kill()

    atexit.register(leave_nothing_running)
    time.sleep(4)
    model = os.path.join(args.out, "bench.nerf")
    for suffix in ("", ".progress"):
        if os.path.exists(model + suffix):
            os.remove(model + suffix)
    cameras = ["cam%d" % i for i in range(4)]
    # Lists cannot be given as _name:=value on a node's command line (roscpp reads them as strings).
    for name, value in (("cameras", "[%s]" % ", ".join(cameras)),
                        ("aabb", "[-0.019, -0.069, -0.069, 0.144, 0.069, 0.069]")):
        subprocess.run(["rosparam", "set", "/nerf_node/" + name, value], env=env, check=True)
    processes["nerf_node"] = start("nerf_node", [
        os.path.join(devel_lib, "nerf_node"), "__name:=nerf_node",
        "_min_frames:=16", "_train_seconds:=0", "_autosave_seconds:=60", "_model_path:=" + model])
    processes["dem_node"] = start("dem_node", [
        os.path.join(devel_lib, "dem_node"), "__name:=dem_node", "_scenario:=" + os.path.join(root, "bench",
                                                                                              "ros_load_scenario.yaml"),
        "_solver:=" + args.solver, "_contact_radius:=0.03"])
    players = []
    for camera in cameras:
        players.append(start("player_" + camera, [
            os.path.join(devel_lib, "dataset_player"), "__name:=player_" + camera, "_data:=" + data,
            "_rate:=30", "_camera:=" + camera, "_frame_prefix:=%s_" % camera]))
        processes["player_" + camera] = players[-1]

    rospy.init_node("ros_load_bench", disable_signals=True)
    lock = threading.Lock()
    statuses = []  # (wall time, iteration, stage)
    displaced = []  # wall times of dem_node results

    def on_status(message):
        with lock:
            statuses.append((time.time(), message.iteration, message.stage, message.frames))

    def on_displaced(_):
        with lock:
            displaced.append(time.time())

    rospy.Subscriber("/nerf_node/status", TrainingStatus, on_status)
    rospy.Subscriber("/dem_node/displaced", PointCloud2, on_displaced)
    broadcaster = tf2_ros.StaticTransformBroadcaster()
    tool = TransformStamped()
    tool.header.stamp = rospy.Time.now()
    tool.header.frame_id = "world"
    tool.child_frame_id = "tool"
    tool.transform.translation.x = 0.125
    tool.transform.rotation.w = 1.0
    broadcaster.sendTransform(tool)
    wrench_publisher = rospy.Publisher("/dem_node/wrench", WrenchStamped, queue_size=10)
    particles_publisher = rospy.Publisher("/particles", PointCloud2, queue_size=1, latch=True)
    sending_wrenches = threading.Event()
    stop = threading.Event()
    wrenches_sent = [0]

    def send_wrenches():
        rate = rospy.Rate(100)
        k = 0
        while not stop.is_set():
            if sending_wrenches.is_set():
                message = WrenchStamped()
                message.header.stamp = rospy.Time(0)
                message.header.frame_id = "tool"
                message.wrench.force.z = -0.5 - 0.5 * ((k % 100) / 100.0)  # changes, so each solve is new
                wrench_publisher.publish(message)
                wrenches_sent[0] += 1
                k += 1
            rate.sleep()

    threading.Thread(target=send_wrenches, daemon=True).start()

    # Warm-up: keyframes in, training running, then particles for dem_node from the NeRF itself.
    deadline = time.time() + 120
    while time.time() < deadline:
        with lock:
            if statuses and statuses[-1][2] == "training" and statuses[-1][1] > 0:
                break
        time.sleep(0.5)
    else:
        print("nerf_node did not start training within 120 s; see %s" % args.out, file=sys.stderr)
    time.sleep(args.warmup_seconds)
    rospy.wait_for_service("/nerf_node/extract", 30)
    extract = rospy.ServiceProxy("/nerf_node/extract", ExtractParticles)(sampler="poisson", spacing=args.spacing)
    print("particles for dem_node: %s" % extract.message, flush=True)
    particles_publisher.publish(extract.cloud)

    def set_phase(phase):
        for player in players:
            if player.poll() is None:
                player.send_signal(signal.SIGCONT if phase != "idle" else signal.SIGSTOP)
        if phase == "all":
            sending_wrenches.set()
        else:
            sending_wrenches.clear()

    samples = []  # (seconds since start, phase, nerf RSS MiB, dem RSS MiB)
    phase_results = []
    start_time = time.time()
    end_time = start_time + 60.0 * args.minutes
    index = 0
    while time.time() < end_time:
        phase = PHASES[index % len(PHASES)]
        set_phase(phase)
        phase_start = time.time()
        phase_end = min(end_time, phase_start + args.phase_seconds)
        cpu_start = {name: cpu_seconds(processes[name].pid) for name in ("nerf_node", "dem_node")}
        while time.time() < phase_end:
            samples.append((round(time.time() - start_time, 1), phase, rss_mib(processes["nerf_node"].pid),
                            rss_mib(processes["dem_node"].pid)))
            time.sleep(min(5.0, max(0.0, phase_end - time.time())))
        # Iterations/s from the status reports inside the phase, skipping its first 3 s.
        with lock:
            inside = [s for s in statuses if phase_start + 3.0 <= s[0] <= phase_end and s[2] == "training"]
            solves = len([t for t in displaced if phase_start <= t <= phase_end])
        rate = (inside[-1][1] - inside[0][1]) / (inside[-1][0] - inside[0][0]) if len(inside) >= 2 else None
        cpu = {name: (cpu_seconds(processes[name].pid) or 0) - (cpu_start[name] or 0) for name in cpu_start}
        phase_results.append({"phase": phase, "seconds": round(phase_end - phase_start, 1),
                              "iterations_per_second": rate, "dem_solves": solves,
                              "nerf_cpu_share": round(cpu["nerf_node"] / (phase_end - phase_start), 2),
                              "dem_cpu_share": round(cpu["dem_node"] / (phase_end - phase_start), 2)})
        print(json.dumps(phase_results[-1]), flush=True)
        index += 1
    set_phase("cameras")
    stop.set()

    crashed = [name for name, process in processes.items() if process.poll() is not None]
    with lock:
        last = statuses[-1] if statuses else None
    for name, process in processes.items():
        if process.poll() is None:
            process.send_signal(signal.SIGINT)
    for name, process in processes.items():
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            process.kill()

    def mean(values):
        values = [v for v in values if v is not None]
        return sum(values) / len(values) if values else None

    by_phase = {p: mean([r["iterations_per_second"] for r in phase_results if r["phase"] == p]) for p in PHASES}
    nerf_rss = [s[2] for s in samples if s[2] is not None]
    dem_rss = [s[3] for s in samples if s[3] is not None]
    half = len(samples) // 2
    summary = {
        "minutes": args.minutes, "phase_seconds": args.phase_seconds, "image_size": args.size, "solver": args.solver,
        "iterations_per_second": by_phase,
        "drop_cameras_percent": None if not by_phase["idle"] or by_phase["cameras"] is None else
        round(100.0 * (1.0 - by_phase["cameras"] / by_phase["idle"]), 1),
        "drop_all_percent": None if not by_phase["idle"] or by_phase["all"] is None else
        round(100.0 * (1.0 - by_phase["all"] / by_phase["idle"]), 1),
        "dem_solves_per_minute_all": mean([60.0 * r["dem_solves"] / r["seconds"] for r in phase_results
                                           if r["phase"] == "all"]),
        "wrenches_sent": wrenches_sent[0],
        "nerf_rss_mib": {"first": nerf_rss[0] if nerf_rss else None, "max": max(nerf_rss) if nerf_rss else None,
                         "last": nerf_rss[-1] if nerf_rss else None,
                         "max_first_half": max(nerf_rss[:half]) if nerf_rss[:half] else None,
                         "max_second_half": max(nerf_rss[half:]) if nerf_rss[half:] else None},
        "dem_rss_mib": {"first": dem_rss[0] if dem_rss else None, "max": max(dem_rss) if dem_rss else None,
                        "last": dem_rss[-1] if dem_rss else None,
                        "max_first_half": max(dem_rss[:half]) if dem_rss[:half] else None,
                        "max_second_half": max(dem_rss[half:]) if dem_rss[half:] else None},
        "final_iteration": last[1] if last else None, "keyframes": last[3] if last else None,
        "crashed": crashed,
    }
    with open(os.path.join(args.out, "rss.csv"), "w") as f:
        f.write("seconds,phase,nerf_rss_mib,dem_rss_mib\n")
        for s in samples:
            f.write("%s,%s,%s,%s\n" % s)
    with open(os.path.join(args.out, "phases.json"), "w") as f:
        json.dump(phase_results, f, indent=1)
    print(json.dumps(summary))
    return 1 if crashed else 0


if __name__ == "__main__":
    sys.exit(main())
