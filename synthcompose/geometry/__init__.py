"""Stage 2 - geometry: disparity <-> depth and the point cloud (depth), the left frame carried to the right view (right_view)."""
