"""Identification of manoeuvring models from trial logs: smoothing, shape, EKF, output error."""
