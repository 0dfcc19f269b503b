"""Typed, documented configuration (YAML through safe_load)."""

from sgpipe.config.loader import load_config
from sgpipe.config.schema import InputPath, OutputName, doc, to_plain

__all__ = ["load_config", "InputPath", "OutputName", "doc", "to_plain"]
