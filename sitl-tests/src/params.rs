//! The autopilot's parameters that the simulation reads (ArduPlane 4.7
//! names and defaults, or the SITL plane's), readable and settable over
//! the PARAM protocol.

use mavlink::dialects::ardupilotmega::MavParamType;

/// One parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    pub name: &'static str,
    pub value: f32,
    pub kind: MavParamType,
}

/// The parameter table, in index order.
#[derive(Debug, Clone, PartialEq)]
pub struct Params {
    list: Vec<Param>,
}

const REAL: MavParamType = MavParamType::MAV_PARAM_TYPE_REAL32;
const INT8: MavParamType = MavParamType::MAV_PARAM_TYPE_INT8;
const INT16: MavParamType = MavParamType::MAV_PARAM_TYPE_INT16;
const INT32: MavParamType = MavParamType::MAV_PARAM_TYPE_INT32;

/// (name, default, type). Names as ArduPlane 4.7 has them.
const TABLE: &[(&str, f32, MavParamType)] = &[
    ("SYSID_THISMAV", 1.0, INT16),
    ("ARMING_CHECK", 1.0, INT32),
    ("AIRSPEED_CRUISE", 22.0, REAL),
    ("AIRSPEED_MIN", 12.0, INT16),
    ("AIRSPEED_MAX", 30.0, INT16),
    ("ROLL_LIMIT_DEG", 45.0, REAL),
    ("PTCH_LIM_MAX_DEG", 20.0, REAL),
    ("TKOFF_ALT", 50.0, REAL),
    ("TKOFF_DIST", 200.0, REAL),
    ("TKOFF_THR_DELAY", 2.0, INT8),
    ("WP_RADIUS", 50.0, INT16),
    ("WP_LOITER_RAD", 60.0, INT16),
    ("RTL_RADIUS", 0.0, INT16),
    ("RTL_ALTITUDE", 100.0, REAL),
    // 0 off, 1 the landing sequence once home is reached, 2 the landing
    // sequence at once (a DO_LAND_START in the mission needs it non-zero
    // to arm).
    ("RTL_AUTOLAND", 0.0, INT8),
    ("LAND_FLARE_ALT", 3.0, REAL),
    ("LAND_FLARE_SEC", 2.0, REAL),
    ("LAND_DISARMDELAY", 20.0, INT8),
    ("TECS_CLMB_MAX", 5.0, REAL),
    ("TECS_SINK_MAX", 5.0, REAL),
    ("TECS_LAND_ARSPD", -1.0, REAL),
    ("TECS_LAND_SINK", 0.25, REAL),
    ("NAVL1_PERIOD", 17.0, REAL),
    ("NAVL1_DAMPING", 0.75, REAL),
    ("BATT_CAPACITY", 3300.0, INT32),
    ("BATT_LOW_MAH", 0.0, REAL),
    ("BATT_CRT_MAH", 0.0, REAL),
    ("BATT_FS_LOW_ACT", 0.0, INT8),
    ("BATT_FS_CRT_ACT", 0.0, INT8),
    ("MIS_TOTAL", 0.0, INT16),
    ("STAT_RUNTIME", 0.0, INT32),
    ("STAT_FLTTIME", 0.0, INT32),
    ("MAV1_RAW_SENS", 0.0, INT16),
    ("MAV1_EXT_STAT", 0.0, INT16),
    ("MAV1_RC_CHAN", 0.0, INT16),
    ("MAV1_RAW_CTRL", 0.0, INT16),
    ("MAV1_POSITION", 0.0, INT16),
    ("MAV1_EXTRA1", 0.0, INT16),
    ("MAV1_EXTRA2", 0.0, INT16),
    ("MAV1_EXTRA3", 0.0, INT16),
    ("MAV1_PARAMS", 0.0, INT16),
    ("MAV1_ADSB", 0.0, INT16),
];

/// The ground rover's table (ArduPilot Rover's names; the defaults are
/// Rover's where the model reads them as Rover does, the model's own
/// otherwise): the shared entries (system id, arming, battery, mission,
/// statistics, stream rates) and the driving ones.
const ROVER_TABLE: &[(&str, f32, MavParamType)] = &[
    ("SYSID_THISMAV", 1.0, INT16),
    ("ARMING_CHECK", 1.0, INT32),
    // m/s: the speed in AUTO, GUIDED and RTL (Rover's default).
    ("CRUISE_SPEED", 2.0, REAL),
    ("CRUISE_THROTTLE", 50.0, INT8),
    // m/s², m/s² and deg/s: the model's limits (Rover's attitude
    // controller's names); ATC_DECEL_MAX 0 brakes at ATC_ACCEL_MAX.
    ("ATC_ACCEL_MAX", 1.0, REAL),
    ("ATC_DECEL_MAX", 0.0, REAL),
    ("ATC_STR_RAT_MAX", 120.0, REAL),
    // m: a waypoint is reached within it (Rover's default).
    ("WP_RADIUS", 2.0, REAL),
    ("WP_SPEED", 0.0, REAL),
    ("RTL_SPEED", 0.0, REAL),
    // 0 HOLD: at the mission's end the rover stops, still in AUTO.
    ("MIS_DONE_BEHAVE", 0.0, INT8),
    ("BATT_CAPACITY", 5000.0, INT32),
    ("BATT_LOW_MAH", 0.0, REAL),
    ("BATT_CRT_MAH", 0.0, REAL),
    ("BATT_FS_LOW_ACT", 0.0, INT8),
    ("BATT_FS_CRT_ACT", 0.0, INT8),
    ("MIS_TOTAL", 0.0, INT16),
    ("STAT_RUNTIME", 0.0, INT32),
    ("MAV1_RAW_SENS", 0.0, INT16),
    ("MAV1_EXT_STAT", 0.0, INT16),
    ("MAV1_RC_CHAN", 0.0, INT16),
    ("MAV1_RAW_CTRL", 0.0, INT16),
    ("MAV1_POSITION", 0.0, INT16),
    ("MAV1_EXTRA1", 0.0, INT16),
    ("MAV1_EXTRA2", 0.0, INT16),
    ("MAV1_EXTRA3", 0.0, INT16),
    ("MAV1_PARAMS", 0.0, INT16),
    ("MAV1_ADSB", 0.0, INT16),
];

fn table(t: &[(&'static str, f32, MavParamType)]) -> Params {
    Params {
        list: t
            .iter()
            .map(|&(name, value, kind)| Param { name, value, kind })
            .collect(),
    }
}

impl Default for Params {
    fn default() -> Self {
        table(TABLE)
    }
}

impl Params {
    /// The table of a firmware: ArduPlane's ([`Params::default`]) or the
    /// rover's.
    pub fn of(firmware: crate::config::Firmware) -> Params {
        match firmware {
            crate::config::Firmware::ArduPlane => table(TABLE),
            crate::config::Firmware::ArduRover => table(ROVER_TABLE),
        }
    }

    /// The value of a parameter (0 for an unknown name: the table is ours).
    pub fn get(&self, name: &str) -> f64 {
        self.list
            .iter()
            .find(|p| p.name == name)
            .map(|p| p.value as f64)
            .unwrap_or(0.0)
    }

    /// Sets a parameter; false when there is no such parameter.
    pub fn set(&mut self, name: &str, value: f32) -> bool {
        match self.list.iter_mut().find(|p| p.name == name) {
            Some(p) => {
                p.value = value;
                true
            }
            None => false,
        }
    }

    /// The index of a parameter.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.list.iter().position(|p| p.name == name)
    }

    pub fn at(&self, index: usize) -> Option<&Param> {
        self.list.get(index)
    }

    pub fn len(&self) -> usize {
        self.list.len()
    }

    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// Whether `name` is a parameter of the table.
    pub fn knows(&self, name: &str) -> bool {
        self.index(name).is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_and_set() {
        let mut p = Params::default();
        assert_eq!(p.get("TKOFF_ALT"), 50.0);
        assert!(p.set("TKOFF_ALT", 80.0));
        assert_eq!(p.get("TKOFF_ALT"), 80.0);
        assert!(!p.set("NOPE", 1.0));
        assert_eq!(p.at(0).map(|x| x.name), Some("SYSID_THISMAV"));
    }
}
