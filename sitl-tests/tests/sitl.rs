//! End-to-end tests of the simulated ArduPlane (one test binary):
//! - `recording`: the simulation driven exactly as the client of ArduPilot's
//!   own SITL recording drove ArduPlane, compared with that recording;
//! - `kinematics`: glide ratio, climb, cruise, bank limit, landing;
//! - `loopback`: the runner over TCP and UDP on 127.0.0.1;
//! - `real_camera`: the camera on its own link, commanded through ArduPilot's
//!   real ArduPlane SITL (instance 8);
//! - `real_parity`: the first minute of a gateway's session on the real
//!   ArduPlane SITL and on the simulation, compared.

// The tests' scratch folders.
use petrel_test_support::scratch;

mod sitl {
    pub mod common;
    mod kinematics;
    mod loopback;
    mod real_camera;
    mod real_parity;
    mod recording;
}
