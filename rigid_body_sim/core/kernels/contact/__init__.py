"""The compiled half of contact (core/contact holds the scene keys and the driver around the step).

``layout`` names the columns of the shape and ground rows; ``shapes`` holds the gap functions
(sphere, box, cylinder, capsule against a half-space) and the features persistent contact
tracks; ``impacts`` the impact law; ``persistent`` the holding force and the projection onto a
resting contact; ``batch`` the passes over every resting body. Like every kernel module they
import only each other, the kernels, numpy, numba and the standard library, so that the
kernels' cache guard (kernels/jit.py, which hashes this folder too) covers them.
"""
