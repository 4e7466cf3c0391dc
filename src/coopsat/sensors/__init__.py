"""Sensor models: star tracker, gyro and their noise, drawn from explicit JAX random keys."""
