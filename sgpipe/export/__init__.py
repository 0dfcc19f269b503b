"""Export of sgpipe artifacts for real-time engines (KTX2 / DDS cubemaps, SH9, glTF)."""
