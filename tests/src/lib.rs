//! End-to-end tests of the `blurlab` command live in `tests/`; this library only gives them the path of the built binary.
