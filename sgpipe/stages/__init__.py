"""Stages: read config + input artifacts, call algorithm packages, write artifacts."""
