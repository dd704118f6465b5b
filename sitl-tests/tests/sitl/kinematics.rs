//! Kinematic checks on the core driven in simulated time.
