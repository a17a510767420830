"""Identification of manoeuvring models from trial logs: reading, smoothing, EKF."""
