"""Every numeric tolerance the tests use, in one table (relax only as a last resort)."""

COMPOSE_MAX_ERR_8BIT = 1  # compose shader vs NumPy, 8-bit levels (issue: <= 1/255)
PROJECTION_PX = 1.0  # GL rasterised corners vs NumPy pinhole projection, pixels
DEPTH_ROUNDTRIP_DISPARITY_PX = 1.0 / 256  # disparity quantisation step, pixels
GROUND_Z_M = 0.05  # placed object's contact point vs the scene's true ground height, metres
#: against the true ground, a pose found on SGM-like stereo may be off by the stereo error too:
#: this many sigma_h (one ground point's height error at the object's depth, from the frame's
#: measured sigma_d) where that is larger than GROUND_Z_M
GROUND_Z_SIGMAS = 2.0


def ground_z_tolerance(noise, depth_m: float) -> float:
    """Largest allowed |contact height - true ground| for an object ``depth_m`` metres away on
    a frame of stereo noise ``noise`` (a placement StereoNoise)."""
    return max(GROUND_Z_M, GROUND_Z_SIGMAS * float(noise.height_sigma(depth_m)))
