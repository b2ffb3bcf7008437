"""Geometry of the head: rigid transforms, pan-tilt kinematics (eq. 3), the frame table,
OpenCV's lens model in numpy, and triangulation (eq. 15–19). numpy and scipy only."""
