"""Measures used by the tests and the benchmarks only (the field's tools run on a batch's
outputs, the stereo pair's checks, the real frames' disparity and photo statistics); not part
of the runtime package and not shipped in the wheel."""
