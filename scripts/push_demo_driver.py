#!/usr/bin/env python3
"""Plays the user for scripts/rviz_push_screenshot.sh: latches a 0.1 m cantilever's particles on
/particles (frame world; clamped at x = 0 by test/data/cuboid_test.yaml), waits for dem_node's
push marker, then drags its z arrow `--drag` metres down and lets go, as rviz would."""
import argparse
import struct

import rospy
from sensor_msgs.msg import PointCloud2, PointField
from visualization_msgs.msg import InteractiveMarkerFeedback, InteractiveMarkerInit


def bar_cloud(h=0.005):
    n, m = round(0.1 / h), round(0.02 / h)
    points = []
    for i in range(n + 1):
        for j in range(m + 1):
            for k in range(m + 1):
                normal = [(-1 if i == 0 else 1 if i == n else 0), (-1 if j == 0 else 1 if j == m else 0),
                          (-1 if k == 0 else 1 if k == m else 0)]
                length = sum(c * c for c in normal) ** 0.5
                normal = [c / length for c in normal] if length else normal
                points.append((i * h, -0.01 + j * h, -0.01 + k * h, h ** 3, *normal, h * h if length else 0.0))
    names = ["x", "y", "z", "volume", "nx", "ny", "nz", "area"]
    cloud = PointCloud2()
    cloud.header.frame_id = "world"
    cloud.header.stamp = rospy.Time.now()
    cloud.height, cloud.width = 1, len(points)
    cloud.fields = [PointField(name, 4 * i, PointField.FLOAT32, 1) for i, name in enumerate(names)]
    cloud.point_step, cloud.row_step = 32, 32 * len(points)
    cloud.data = b"".join(struct.pack("<8f", *p) for p in points)
    return cloud


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--drag", type=float, default=0.03)
    args = parser.parse_args(rospy.myargv()[1:])
    rospy.init_node("push_demo_driver")
    particles = rospy.Publisher("/particles", PointCloud2, queue_size=1, latch=True)
    feedback = rospy.Publisher("/dem_node/push/feedback", InteractiveMarkerFeedback, queue_size=10)
    particles.publish(bar_cloud())
    # The server's first full update may come before the particles: wait for one with the marker.
    rest = None
    deadline = rospy.Time.now() + rospy.Duration(60)
    while rest is None and rospy.Time.now() < deadline and not rospy.is_shutdown():
        init = rospy.wait_for_message("/dem_node/push/update_full", InteractiveMarkerInit, timeout=60)
        rest = next((marker.pose for marker in init.markers if marker.name == "push"), None)
        if rest is None:
            rospy.sleep(0.5)
    if rest is None:
        raise SystemExit("no push marker from dem_node within 60 s")
    while feedback.get_num_connections() == 0 and not rospy.is_shutdown():
        rospy.sleep(0.1)
    message = InteractiveMarkerFeedback(marker_name="push", control_name="push_z", client_id="/push_demo_driver")
    message.header.frame_id = "world"
    message.pose = rest
    message.pose.position.z -= args.drag
    for event in (InteractiveMarkerFeedback.MOUSE_DOWN, InteractiveMarkerFeedback.POSE_UPDATE,
                  InteractiveMarkerFeedback.MOUSE_UP):
        message.event_type = event
        message.header.stamp = rospy.Time.now()
        feedback.publish(message)
        rospy.sleep(0.1)
    rospy.spin()  # keeps /particles latched for rviz


if __name__ == "__main__":
    main()
