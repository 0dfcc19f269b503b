"""Primary visibility shared by the OpenCL methods (`sgpipe.render`) and the Monte Carlo
reference (`sgpipe.reference`): the pinhole camera (`camera`) and the Embree / analytic-sphere
tracer with its G-buffer (`gbuffer`). Both algorithm packages trace the same rays through the
same code, and neither imports the other; this package imports only core and errors."""
