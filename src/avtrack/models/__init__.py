"""Observation and dynamics models that plug into the VEM engine."""
