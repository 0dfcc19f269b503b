"""The files stages exchange (docs/ARTIFACTS.md), one module per producing stage: `fit`,
`envmap`, `visibility`, `render`. Each holds the file names and layout constants, the writers
its stage calls (through anything with a stage's `write_exr` / `write_npz` / `write_json`
interface: a `StageRun`, or `FolderSink` for tests and tools) and the readers its consumers
call (plain arrays and small dataclasses; a malformed file is one BadInput line naming file and
key). Imports only sgpipe.io, sgpipe.errors and sgpipe.core, so every algorithm package and
stage may use it without importing another algorithm package."""

from sgpipe.artifacts._common import FolderSink, scalar

__all__ = ["FolderSink", "scalar"]
