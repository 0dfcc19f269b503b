"""The OpenCL shading methods: the method registry (`methods`), the records and generated
headers the kernels read (`records`, `headers`), the kernels (`kernels/*.cl`, `include/*.h`),
the host side (`renderer`, `opencl`) and its assembly from a config and the upstream artifacts
(`setup`, `envdata`, `materials`, `scene`). Primary rays: sgpipe.scene; the Monte Carlo
reference: sgpipe.reference; image metrics: sgpipe.metrics."""
