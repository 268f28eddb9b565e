"""Every numeric tolerance the tests use, in one table (relax only as a last resort)."""

COMPOSE_MAX_ERR_8BIT = 1  # compose shader vs NumPy, 8-bit levels (issue: <= 1/255)
PROJECTION_PX = 1.0  # GL rasterised corners vs NumPy pinhole projection, pixels
DEPTH_ROUNDTRIP_DISPARITY_PX = 1.0 / 256  # disparity quantisation step, pixels
GROUND_Z_M = 0.05  # placed object's contact point vs the scene's true ground height, metres
