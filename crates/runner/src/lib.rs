//! The experiment runner: schedules, presentation, stereo display modes, calibration, durable response logs and simulated observers.
