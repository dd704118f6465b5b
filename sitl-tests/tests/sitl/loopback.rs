//! The runner over 127.0.0.1.
