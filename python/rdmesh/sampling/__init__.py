"""Sampling the surface: crossings along segments, the seeding grid, critical
points and probes."""
