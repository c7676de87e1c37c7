//! The distribution ray tracer: CPU reference.
