"""Han07 (Han, Sun, Ramamoorthi, Grinspun 2007, "Frequency Domain Normal Map Filtering"):
normal-map reading (`read`), the MIP pyramid of covered normals and the single-lobe baselines
(`pyramid`), the spherical-harmonic method (`sh`), the vMF method (`vmf`, compiled core in
`_vmf_jit`) and the lobe closed forms (`lobes`). docs/HAN07.md describes the whole."""
