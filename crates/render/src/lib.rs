//! Pixels from a stimulus: the CPU distribution ray tracer (and later its GPU twin, the post-process filters and the analytic rasterizer).
