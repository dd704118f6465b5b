//! The simulation's configuration.

use crate::boot::BootTimeline;
use crate::faults::Schedule;
use crate::geo::Home;
use crate::model::Airframe;

/// Which ArduPilot firmware the simulated autopilot behaves as on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Firmware {
    /// ArduPlane 4.7: a fixed-wing aircraft (HEARTBEAT type FIXED_WING).
    #[default]
    ArduPlane,
    /// ArduPilot Rover: a ground rover (HEARTBEAT type GROUND_ROVER), its
    /// modes and navigation (`crate::rover`), a kinematic model
    /// (`crate::drive`).
    ArduRover,
}

/// Everything the simulation is started with. The vehicle core reads all
/// but `listen` and `speedup`, which are the runner's.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// Where to listen: `tcpin:IP:PORT` (one client at a time, as ArduPilot
    /// SITL's TCP port) or `udpin:IP:PORT` (replies go to the last sender).
    /// Port 0 picks a free port (see `Sim::local_addr`).
    pub listen: String,
    /// The firmware the vehicle behaves as.
    pub firmware: Firmware,
    /// Sim time = speedup × wall time (1 for a demo, 10–100 for tests).
    pub speedup: f64,
    pub home: Home,
    /// Constant wind (m/s toward north, toward east).
    pub wind: (f64, f64),
    /// Refuse arming until the gyros have settled (`boot.gyros_settled`)
    /// with "Arm: Gyros inconsistent", as real ArduPlane SITL refuses its
    /// first arming soon after boot.
    pub first_arm_refused: bool,
    /// Faults to inject during the run.
    pub faults: Schedule,
    /// The vehicle's MAVLink system id.
    pub system_id: u8,
    /// The camera component (100) is there.
    pub camera: bool,
    /// The engine reports EFI_STATUS (a combustion engine; the recorded SITL
    /// plane is electric and has none).
    pub efi: bool,
    /// SERVO_OUTPUT_RAW at 50 Hz, all zero, while INITIALISING, unasked, as
    /// the recording shows.
    pub boot_servo_burst: bool,
    pub airframe: Airframe,
    pub boot: BootTimeline,
    /// The rate (Hz) of every REQUEST_DATA_STREAM group before anyone asks
    /// (ArduPlane's MAVn_* parameters): 1, as ArduPlane 4.7 SITL with
    /// `plane.parm` streams every group at 1 Hz on every serial port from
    /// start-up; 0 streams nothing but HEARTBEAT until asked.
    pub stream_hz: u16,
    /// Parameters set at boot over ArduPlane's defaults (`TKOFF_ALT`,
    /// `AIRSPEED_CRUISE`, `ROLL_LIMIT_DEG`, `WP_RADIUS`, …).
    pub params: Vec<(String, f32)>,
    /// The physics step (sim µs).
    pub step_us: u64,
    /// UNIX time at boot (µs), for SYSTEM_TIME and GPS time.
    pub unix_boot_us: u64,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            listen: "tcpin:127.0.0.1:0".to_owned(),
            firmware: Firmware::ArduPlane,
            speedup: 1.0,
            home: Home::default(),
            wind: (0.0, 0.0),
            first_arm_refused: true,
            faults: Schedule::default(),
            system_id: 1,
            camera: true,
            efi: true,
            boot_servo_burst: true,
            airframe: Airframe::default(),
            boot: BootTimeline::default(),
            stream_hz: 1,
            params: Vec::new(),
            step_us: 20_000,
            unix_boot_us: 1_795_238_459_000_000,
        }
    }
}

impl SimConfig {
    /// A ground rover with system id `system_id`: ArduPilot Rover on the
    /// wire, no camera, no EFI, no boot servo burst, its own airframe and
    /// parameters; parked at `home`.
    pub fn rover(system_id: u8, home: Home) -> SimConfig {
        SimConfig {
            firmware: Firmware::ArduRover,
            system_id,
            home,
            camera: false,
            efi: false,
            boot_servo_burst: false,
            airframe: Airframe::rover(),
            ..SimConfig::default()
        }
    }
}
