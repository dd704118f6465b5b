//! The messages the vehicle sends, built from its state with the fields as
//! ArduPlane SITL fills them (values copied from the recording where they
//! are constants of the simulator: RC inputs, IMU temperature, memory…).

use mavlink::dialects::ardupilotmega::*;

use crate::boot::Phase;
use crate::camera::{self, Output};
use crate::faults::FaultKind;
use crate::geo::{e7, location, V2};
use crate::model::G;
use crate::modes;
use crate::state::{CameraAction, CameraEvent};
use crate::streams::id;
use crate::vehicle::Vehicle;

mod bits {
    pub const GYRO: u32 = 0x1;
    pub const ACCEL: u32 = 0x2;
    pub const MAG: u32 = 0x4;
    pub const BARO: u32 = 0x8;
    pub const DIFF_PRESSURE: u32 = 0x10;
    pub const GPS: u32 = 0x20;
    /// Angular rate, attitude, yaw, altitude and position control.
    pub const CONTROL: u32 = 0x7c00;
    pub const MOTORS: u32 = 0x8000;
    pub const RC: u32 = 0x1_0000;
    pub const GEOFENCE: u32 = 0x10_0000;
    pub const AHRS: u32 = 0x20_0000;
    pub const TERRAIN: u32 = 0x40_0000;
    pub const LOGGING: u32 = 0x100_0000;
    pub const BATTERY: u32 = 0x200_0000;
    pub const PREARM: u32 = 0x1000_0000;
}

/// ISA pressure (hPa) at `alt` metres AMSL.
fn pressure_hpa(alt: f64) -> f64 {
    1013.25 * (1.0 - 2.255_77e-5 * alt).powf(5.255_88)
}

impl Vehicle {
    fn boot_ms(&self) -> u32 {
        (self.now / 1000) as u32
    }

    /// No navigation outputs (NAV_CONTROLLER_OUTPUT,
    /// POSITION_TARGET_GLOBAL_INT) in this mode: ArduPlane's MANUAL, a
    /// rover's modes that are not autopilot modes.
    fn manual_mode(&self) -> bool {
        if self.is_rover() {
            return !modes::rover::is_autopilot(self.fl.mode);
        }
        self.fl.mode == modes::MANUAL || self.fl.mode == modes::INITIALISING
    }

    fn latlon(&self, at: V2) -> (i32, i32) {
        let (lat, lon) = location(self.origin(), at);
        (e7(lat), e7(lon))
    }

    fn alt_amsl(&self) -> f64 {
        self.origin().alt_amsl + self.ac.alt
    }

    /// GPS_RAW_INT.fix_type as a number.
    pub(crate) fn gps_fix(&self) -> u8 {
        if !self.boot.has(Phase::Gps) {
            0
        } else if self.has_fault(FaultKind::GpsLoss) {
            1
        } else {
            6
        }
    }

    /// The EKF's status flags; `None` before the EKF starts.
    pub(crate) fn ekf_flags(&self) -> Option<u16> {
        let b = &self.boot;
        if !b.has(Phase::EkfStart) {
            return None;
        }
        Some(
            if self.has_fault(FaultKind::GpsLoss) && b.has(Phase::EkfGps) {
                // Dead reckoning: attitude and height, no horizontal aiding.
                0x0025
            } else if b.has(Phase::EkfGps) {
                0x033f
            } else if b.has(Phase::EkfAligned) {
                0x00a7
            } else if b.has(Phase::EkfInit) {
                0x0000
            } else {
                0x0400
            },
        )
    }

    fn sensors(&self) -> (u32, u32, u32) {
        use bits::*;
        let base = GYRO | ACCEL | MAG | BARO | DIFF_PRESSURE;
        let gps = if self.boot.has(Phase::Gps) { GPS } else { 0 };
        let guided = !self.manual_mode();
        let present =
            base | CONTROL | MOTORS | RC | AHRS | LOGGING | BATTERY | PREARM | TERRAIN | gps;
        let mut enabled = base | MOTORS | RC | BATTERY | PREARM | TERRAIN | gps;
        // As ArduPlane 4.7 SITL: the controllers in the modes that fly
        // themselves, the AHRS once the EKF is active, logging while armed.
        let ekf = self.boot.has(Phase::EkfGps);
        if guided {
            enabled |= CONTROL;
        }
        if ekf {
            enabled |= AHRS;
        }
        if self.fl.armed {
            enabled |= LOGGING;
        }
        let mut health = GYRO | ACCEL | MAG | BARO | MOTORS | RC | GEOFENCE | LOGGING | BATTERY;
        if self.boot.has(Phase::AirspeedCalibrated) {
            health |= DIFF_PRESSURE;
        }
        if self.gps_fix() >= 3 {
            health |= GPS;
        }
        if guided {
            health |= CONTROL;
        }
        if (ekf || guided) && !self.has_fault(FaultKind::GpsLoss) {
            health |= AHRS;
        }
        if self.fl.armed || self.prearm_failures().is_empty() {
            health |= PREARM;
        }
        if self.fl.battery_failsafe > 0 {
            health &= !BATTERY;
        }
        (present, enabled, health)
    }

    pub(crate) fn send_heartbeat(&mut self) {
        let msg = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: self.fl.mode,
            mavtype: if self.is_rover() {
                MavType::MAV_TYPE_GROUND_ROVER
            } else {
                MavType::MAV_TYPE_FIXED_WING
            },
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: if self.is_rover() {
                modes::rover::base_mode(self.fl.mode, self.fl.armed)
            } else {
                modes::base_mode(self.fl.mode, self.fl.armed)
            },
            system_status: self.system_status(),
            mavlink_version: 3,
        });
        self.send(msg);
    }

    pub(crate) fn camera_output(&mut self, o: Output) {
        let at = self.fix();
        if let Output::Image { index } = o {
            self.truth.camera.push(CameraEvent {
                at,
                action: CameraAction::Image { index },
            });
        }
        let context = camera::Context {
            time_boot_ms: self.boot_ms(),
            time_utc_us: self.cfg.unix_boot_us + self.now,
            lat: e7(at.lat),
            lon: e7(at.lon),
            alt_mm: (self.alt_amsl() * 1000.0) as i32,
            relative_alt_mm: (self.ac.alt * 1000.0) as i32,
        };
        let msg = self.camera.message(o, &context);
        self.send_from(camera::COMPONENT, msg);
    }

    /// HOME_POSITION, and GPS_GLOBAL_ORIGIN once the EKF has its origin.
    pub(crate) fn send_home(&mut self) {
        if self.send_home_position() && self.boot.has(Phase::Origin) {
            self.send_origin();
        }
    }

    /// HOME_POSITION alone (as streamed: SITL sends GPS_GLOBAL_ORIGIN on
    /// its own, every few seconds); false before home is set.
    pub(crate) fn send_home_position(&mut self) -> bool {
        if !self.home_set {
            return false;
        }
        let (lat, lon) = self.latlon(self.home_pos);
        let alt = (self.origin().alt_amsl * 1000.0) as i32;
        let origin = self.boot.has(Phase::Origin);
        let (x, y, z) = if origin {
            (self.home_pos.n as f32, self.home_pos.e as f32, -0.0)
        } else {
            (f32::NAN, f32::NAN, f32::NAN)
        };
        let time_usec = self.now;
        self.send(MavMessage::HOME_POSITION(HOME_POSITION_DATA {
            latitude: lat,
            longitude: lon,
            altitude: alt,
            x,
            y,
            z,
            q: [f32::NAN; 4],
            approach_x: 0.0,
            approach_y: 0.0,
            approach_z: 0.0,
            time_usec,
        }));
        true
    }

    fn send_origin(&mut self) {
        let (lat, lon) = self.latlon(V2::ZERO);
        self.send(MavMessage::GPS_GLOBAL_ORIGIN(GPS_GLOBAL_ORIGIN_DATA {
            latitude: lat,
            longitude: lon,
            altitude: (self.origin().alt_amsl * 1000.0) as i32,
            time_usec: self.now,
        }));
    }

    /// PARAM_VALUE of a parameter named (a read by name, the answer to
    /// PARAM_SET, a notification): ArduPilot leaves param_index at 65535
    /// there, as it was asked by name.
    pub(crate) fn send_param(&mut self, name: &str) {
        let Some(index) = self.params.index(name) else {
            return;
        };
        self.send_param_value(index, u16::MAX);
    }

    /// PARAM_VALUE of the parameter at `index` (PARAM_REQUEST_LIST, a read
    /// by index): param_index is the index.
    pub(crate) fn send_param_at(&mut self, index: usize) {
        self.send_param_value(index, index as u16);
    }

    fn send_param_value(&mut self, index: usize, param_index: u16) {
        let Some(p) = self.params.at(index).cloned() else {
            return;
        };
        let msg = MavMessage::PARAM_VALUE(PARAM_VALUE_DATA {
            param_value: p.value,
            param_count: self.params.len() as u16,
            param_index,
            param_id: p.name.into(),
            param_type: p.kind,
        });
        self.send(msg);
    }

    /// STAT_RUNTIME / STAT_FLTTIME, as ArduPilot saves them every 30 s.
    pub(crate) fn send_stats(&mut self) {
        let run = (self.now / 1_000_000) as f32;
        let flt = (self.fl.flight_time_us / 1_000_000) as f32;
        self.params.set("STAT_RUNTIME", run);
        self.params.set("STAT_FLTTIME", flt);
        self.send_param("STAT_FLTTIME");
        self.send_param("STAT_RUNTIME");
    }

    pub(crate) fn send_timesync(&mut self) {
        let ns = (self.now * 1000) as i64;
        self.send(MavMessage::TIMESYNC(TIMESYNC_DATA {
            tc1: 0,
            ts1: ns,
            target_system: 0,
            target_component: 0,
        }));
    }

    pub(crate) fn send_servo_output(&mut self, boot: bool) {
        let s = &self.servos;
        let (s1, s2, s3, s4) = if boot {
            (0, 0, 0, 0)
        } else {
            let ail = 1500.0 + 500.0 * (self.fl.nav_roll - self.ac.bank).clamp(-1.0, 1.0);
            let elev = 1500.0 + 300.0 * (self.ac.climb / 10.0).clamp(-1.0, 1.0);
            let thr = 1000.0 + 1000.0 * self.ac.throttle;
            (ail as u16, elev as u16, thr as u16, 1500)
        };
        let pick = |i: usize| if boot { 0 } else { s[i] };
        let msg = MavMessage::SERVO_OUTPUT_RAW(SERVO_OUTPUT_RAW_DATA {
            time_usec: self.now as u32,
            servo1_raw: s1,
            servo2_raw: s2,
            servo3_raw: s3,
            servo4_raw: s4,
            servo5_raw: pick(4),
            servo6_raw: pick(5),
            servo7_raw: pick(6),
            servo8_raw: pick(7),
            port: 0,
            servo9_raw: pick(8),
            servo10_raw: pick(9),
            servo11_raw: pick(10),
            servo12_raw: pick(11),
            servo13_raw: pick(12),
            servo14_raw: pick(13),
            servo15_raw: pick(14),
            servo16_raw: pick(15),
        });
        self.send(msg);
    }

    pub(crate) fn mission_state(&self) -> MissionState {
        if self.mission.len() <= 1 {
            MissionState::MISSION_STATE_NO_MISSION
        } else if self.auto.complete {
            MissionState::MISSION_STATE_COMPLETE
        } else if self.auto.running {
            MissionState::MISSION_STATE_ACTIVE
        } else if self.auto.current == 0 {
            MissionState::MISSION_STATE_NOT_STARTED
        } else {
            MissionState::MISSION_STATE_PAUSED
        }
    }

    pub(crate) fn mission_current(&self) -> MavMessage {
        MavMessage::MISSION_CURRENT(MISSION_CURRENT_DATA {
            seq: self.auto.current,
            total: self.mission.len().saturating_sub(1) as u16,
            mission_state: self.mission_state(),
            mission_mode: (self.fl.mode == modes::AUTO) as u8,
            mission_id: 0,
            fence_id: 0,
            rally_points_id: 0,
        })
    }

    pub(crate) fn autopilot_version(&self) -> MavMessage {
        use MavProtocolCapability as C;
        MavMessage::AUTOPILOT_VERSION(AUTOPILOT_VERSION_DATA {
            capabilities: C::MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
                | C::MAV_PROTOCOL_CAPABILITY_MISSION_INT
                | C::MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                | C::MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
                | C::MAV_PROTOCOL_CAPABILITY_TERRAIN
                | C::MAV_PROTOCOL_CAPABILITY_MAVLINK2,
            uid: 0,
            flight_sw_version: (4 << 24) | (7 << 16),
            middleware_sw_version: 0,
            os_sw_version: 0,
            board_version: 0,
            vendor_id: 0,
            product_id: 0,
            flight_custom_version: *b"90700977",
            middleware_custom_version: [0; 8],
            os_custom_version: [0; 8],
            uid2: [0; 18],
        })
    }

    /// Sends a streamed message (or the one asked by REQUEST_MESSAGE).
    /// Returns false when the message cannot be sent now.
    pub(crate) fn send_stream(&mut self, m: u32) -> bool {
        if m == id::MISSION_ITEM_REACHED {
            // ArduPilot re-sends the last one (65535 before any).
            let seq = self.last_reached;
            self.send(MavMessage::MISSION_ITEM_REACHED(
                MISSION_ITEM_REACHED_DATA { seq },
            ));
            return true;
        }
        if m == id::AUTOPILOT_VERSION {
            let v = self.autopilot_version();
            self.send(v);
            return true;
        }
        if m == id::SERVO_OUTPUT_RAW {
            self.send_servo_output(false);
            return true;
        }
        if m == id::HOME_POSITION {
            return self.send_home_position();
        }
        if m == id::TERRAIN_REPORT && self.gps_ok() {
            // MSG_TERRAIN: a TERRAIN_REQUEST every seventh time (0.57 Hz at
            // 4 Hz, as recorded), then the report.
            self.next_terrain_request += 1;
            if self.next_terrain_request % 7 == 1 {
                let (lat, lon) = self.latlon(V2::new(-1281.0, -947.0));
                self.send(MavMessage::TERRAIN_REQUEST(TERRAIN_REQUEST_DATA {
                    mask: 0x00ff_ffff_ffff_ffff,
                    lat,
                    lon,
                    grid_spacing: 100,
                }));
            }
        }
        match self.build(m) {
            Some(msg) => {
                self.send(msg);
                true
            }
            None => false,
        }
    }

    /// Builds a streamed message; `None` when ArduPlane would not send it
    /// now (NAV_CONTROLLER_OUTPUT in MANUAL, the EKF's before it starts…).
    fn build(&mut self, m: u32) -> Option<MavMessage> {
        let ms = self.boot_ms();
        let us = self.now;
        let ac = &self.ac;
        let alt_amsl = self.alt_amsl();
        let (lat, lon) = self.latlon(ac.pos);
        let gps = self.boot.has(Phase::Gps);
        let located = self.home_set;
        let load = 1.0 / ac.bank.cos().max(0.2);
        let turn_rate = if ac.on_ground {
            0.0
        } else {
            G * ac.bank.tan() / ac.airspeed.max(1.0)
        };
        let yaw_pi = crate::geo::wrap_pi(ac.heading);
        let hdg_deg = ac.heading.to_degrees().rem_euclid(360.0);
        let aspd = ac.indicated_airspeed();
        let q = 0.5 * 1.225 * aspd * aspd; // Pa (from the equivalent airspeed)
        let vel = ac.ground_vel;
        let imu_acc = (
            (ac.accel / G * 1000.0) as i16,
            0i16,
            (-1000.0 * if ac.on_ground { 1.0 } else { load }) as i16,
        );
        let mag = {
            let h = V2::new(250.0, 0.0).rotated(-ac.heading);
            (h.n as i16, h.e as i16, -528i16)
        };
        Some(match m {
            id::SYS_STATUS => {
                let (p, e, h) = self.sensors();
                MavMessage::SYS_STATUS(SYS_STATUS_DATA {
                    onboard_control_sensors_present: MavSysStatusSensor::from_bits_retain(p),
                    onboard_control_sensors_enabled: MavSysStatusSensor::from_bits_retain(e),
                    onboard_control_sensors_health: MavSysStatusSensor::from_bits_retain(h),
                    load: 0,
                    voltage_battery: (self.ac.battery.voltage * 1000.0) as u16,
                    current_battery: (self.ac.battery.current * 100.0) as i16,
                    drop_rate_comm: 0,
                    errors_comm: 0,
                    errors_count1: 0,
                    errors_count2: 0,
                    errors_count3: 0,
                    errors_count4: 0,
                    battery_remaining: self.battery_remaining().round() as i8,
                    // None (rust-mavlink's Default is the first flag).
                    onboard_control_sensors_present_extended: MavSysStatusSensorExtended::empty(),
                    onboard_control_sensors_enabled_extended: MavSysStatusSensorExtended::empty(),
                    onboard_control_sensors_health_extended: MavSysStatusSensorExtended::empty(),
                })
            }
            id::POWER_STATUS => MavMessage::POWER_STATUS(POWER_STATUS_DATA {
                Vcc: 5000,
                Vservo: 0,
                flags: MavPowerStatus::empty(),
            }),
            id::MEMINFO => MavMessage::MEMINFO(MEMINFO_DATA {
                brkval: 0,
                freemem: 65535,
                freemem32: 524_288,
            }),
            id::MISSION_CURRENT => self.mission_current(),
            id::GPS_RAW_INT => {
                let fix = self.gps_fix();
                let gps_us = us / 200_000 * 200_000;
                if !gps {
                    MavMessage::GPS_RAW_INT(GPS_RAW_INT_DATA {
                        eph: 65535,
                        epv: 65535,
                        ..Default::default()
                    })
                } else {
                    let good = fix >= 3;
                    MavMessage::GPS_RAW_INT(GPS_RAW_INT_DATA {
                        time_usec: gps_us,
                        lat,
                        lon,
                        alt: (alt_amsl * 1000.0) as i32,
                        eph: if good { 121 } else { 9999 },
                        epv: if good { 200 } else { 9999 },
                        vel: (vel.len() * 100.0) as u16,
                        cog: (vel.heading().to_degrees() * 100.0) as u16 % 36000,
                        fix_type: num_traits::FromPrimitive::from_u8(fix).unwrap_or_default(),
                        satellites_visible: if good { 10 } else { 0 },
                        alt_ellipsoid: (alt_amsl * 1000.0) as i32,
                        h_acc: if good { 300 } else { 99_999 },
                        v_acc: if good { 300 } else { 99_999 },
                        vel_acc: 0,
                        hdg_acc: 0,
                        yaw: 0,
                    })
                }
            }
            id::NAV_CONTROLLER_OUTPUT => {
                if self.manual_mode() {
                    return None;
                }
                let nav = self.fl.nav;
                let bearing = |r: f64| {
                    let d = r.to_degrees().rem_euclid(360.0);
                    (if d > 180.0 { d - 360.0 } else { d }).round() as i16
                };
                MavMessage::NAV_CONTROLLER_OUTPUT(NAV_CONTROLLER_OUTPUT_DATA {
                    nav_roll: self.fl.nav_roll.to_degrees() as f32,
                    nav_pitch: (self.ac.pitch.to_degrees()) as f32,
                    alt_error: (self.fl.alt_target - ac.alt) as f32,
                    aspd_error: ((self.fl.speed_target - aspd) * 100.0) as f32,
                    xtrack_error: nav.xtrack as f32,
                    nav_bearing: bearing(nav.nav_bearing),
                    target_bearing: bearing(nav.target_bearing),
                    wp_dist: nav.wp_dist.min(65535.0) as u16,
                })
            }
            id::POSITION_TARGET_GLOBAL_INT => {
                if self.manual_mode() {
                    return None;
                }
                let (p, a) = self.fl.target.unwrap_or((ac.pos, ac.alt));
                let (tlat, tlon) = self.latlon(p);
                MavMessage::POSITION_TARGET_GLOBAL_INT(POSITION_TARGET_GLOBAL_INT_DATA {
                    time_boot_ms: ms,
                    lat_int: tlat,
                    lon_int: tlon,
                    alt: (self.origin().alt_amsl + a) as f32,
                    type_mask: PositionTargetTypemask::from_bits_retain(0xfdf8),
                    coordinate_frame: MavFrame::MAV_FRAME_GLOBAL,
                    ..Default::default()
                })
            }
            id::GLOBAL_POSITION_INT => {
                let (la, lo, alt) = if located {
                    (lat, lon, (alt_amsl * 1000.0) as i32)
                } else {
                    (0, 0, (ac.alt * 1000.0) as i32)
                };
                MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
                    time_boot_ms: ms,
                    lat: la,
                    lon: lo,
                    alt,
                    relative_alt: (ac.alt * 1000.0) as i32,
                    vx: (vel.n * 100.0) as i16,
                    vy: (vel.e * 100.0) as i16,
                    vz: (-ac.climb * 100.0) as i16,
                    hdg: (hdg_deg * 100.0) as u16 % 36000,
                })
            }
            id::LOCAL_POSITION_NED => {
                if !self.boot.has(Phase::EkfInit) {
                    return None;
                }
                MavMessage::LOCAL_POSITION_NED(LOCAL_POSITION_NED_DATA {
                    time_boot_ms: ms,
                    x: ac.pos.n as f32,
                    y: ac.pos.e as f32,
                    z: -ac.alt as f32,
                    vx: vel.n as f32,
                    vy: vel.e as f32,
                    vz: -ac.climb as f32,
                })
            }
            id::RC_CHANNELS => MavMessage::RC_CHANNELS(RC_CHANNELS_DATA {
                time_boot_ms: ms,
                chan1_raw: 1500,
                chan2_raw: 1500,
                chan3_raw: 1000,
                chan4_raw: 1500,
                chan5_raw: 1800,
                chan6_raw: 1000,
                chan7_raw: 1000,
                chan8_raw: 1800,
                chancount: 8,
                rssi: 255,
                ..Default::default()
            }),
            id::ATTITUDE => MavMessage::ATTITUDE(ATTITUDE_DATA {
                time_boot_ms: ms,
                roll: ac.bank as f32,
                pitch: ac.pitch as f32,
                yaw: yaw_pi as f32,
                rollspeed: ac.roll_rate as f32,
                pitchspeed: 0.0,
                yawspeed: turn_rate as f32,
            }),
            id::SIMSTATE => MavMessage::SIMSTATE(SIMSTATE_DATA {
                roll: ac.bank as f32,
                pitch: ac.pitch as f32,
                yaw: yaw_pi as f32,
                xacc: ac.accel as f32,
                yacc: 0.0,
                zacc: (-G * if ac.on_ground { 1.0 } else { load }) as f32,
                xgyro: ac.roll_rate as f32,
                ygyro: 0.0,
                zgyro: turn_rate as f32,
                lat,
                lng: lon,
            }),
            id::AHRS2 => {
                if !self.boot.has(Phase::EkfInit) {
                    return None;
                }
                MavMessage::AHRS2(AHRS2_DATA {
                    roll: ac.bank as f32,
                    pitch: ac.pitch as f32,
                    yaw: yaw_pi as f32,
                    altitude: alt_amsl as f32,
                    lat,
                    lng: lon,
                })
            }
            id::AOA_SSA => MavMessage::AOA_SSA(AOA_SSA_DATA {
                time_usec: us,
                AOA: if ac.on_ground {
                    0.0
                } else {
                    (ac.pitch - (ac.climb / ac.airspeed.max(1.0)).asin()).to_degrees() as f32
                },
                SSA: 0.0,
            }),
            id::ESC_TELEMETRY_1_TO_4 => {
                if !self.boot.has(Phase::Esc) {
                    return None;
                }
                self.esc_count = self.esc_count.wrapping_add(1);
                MavMessage::ESC_TELEMETRY_1_TO_4(ESC_TELEMETRY_1_TO_4_DATA {
                    voltage: [0, 0, 1679, 0],
                    current: [0, 0, 80, 0],
                    totalcurrent: [0, 0, 1, 0],
                    rpm: [0, 0, self.ac.engine.rpm.min(65535.0) as u16, 0],
                    count: [0, 0, self.esc_count, 0],
                    temperature: [0, 0, 32, 0],
                })
            }
            id::EFI_STATUS => {
                if !self.cfg.efi {
                    return None;
                }
                let thr = (self.ac.throttle * 100.0) as f32;
                let running = self.ac.engine.rpm > 0.0;
                MavMessage::EFI_STATUS(EFI_STATUS_DATA {
                    health: 1,
                    ecu_index: 0.0,
                    rpm: self.ac.engine.rpm as f32,
                    fuel_consumed: 0.0,
                    fuel_flow: if running { 5.0 + 0.6 * thr } else { 0.0 },
                    engine_load: thr,
                    throttle_position: thr,
                    spark_dwell_time: 0.0,
                    barometric_pressure: (pressure_hpa(alt_amsl) / 10.0) as f32,
                    intake_manifold_pressure: (pressure_hpa(alt_amsl) / 10.0) as f32,
                    intake_manifold_temperature: 300.0,
                    cylinder_head_temperature: if running { 150.0 } else { 30.0 },
                    ignition_timing: if running { 20.0 } else { 0.0 },
                    injection_time: 0.0,
                    exhaust_gas_temperature: if running { 600.0 } else { 30.0 },
                    throttle_out: thr,
                    pt_compensation: 0.0,
                    ignition_voltage: 12.0,
                    fuel_pressure: 0.0,
                })
            }
            id::VFR_HUD => MavMessage::VFR_HUD(VFR_HUD_DATA {
                airspeed: aspd as f32,
                groundspeed: vel.len() as f32,
                alt: if located {
                    alt_amsl as f32
                } else {
                    ac.alt as f32
                },
                climb: ac.climb as f32,
                heading: hdg_deg as i16,
                throttle: (self.ac.throttle * 100.0).round() as u16,
            }),
            id::AHRS => MavMessage::AHRS(AHRS_DATA {
                omegaIx: 0.000_25,
                omegaIy: 0.000_01,
                omegaIz: 0.000_01,
                accel_weight: 0.0,
                renorm_val: 0.0,
                error_rp: if ac.on_ground { 0.0007 } else { 0.05 },
                error_yaw: 0.0001,
            }),
            id::WIND => {
                let w = ac.wind;
                MavMessage::WIND(WIND_DATA {
                    direction: (-w.e).atan2(-w.n).to_degrees() as f32,
                    speed: w.len() as f32,
                    speed_z: 0.0,
                })
            }
            id::SYSTEM_TIME => MavMessage::SYSTEM_TIME(SYSTEM_TIME_DATA {
                time_unix_usec: self.cfg.unix_boot_us + us,
                time_boot_ms: ms,
            }),
            id::TERRAIN_REPORT => MavMessage::TERRAIN_REPORT(TERRAIN_REPORT_DATA {
                lat: if gps { lat } else { 0 },
                lon: if gps { lon } else { 0 },
                terrain_height: 0.0,
                current_height: if located {
                    alt_amsl as f32
                } else {
                    ac.alt as f32
                },
                spacing: if gps { 0 } else { 100 },
                pending: if gps { 504 } else { 56 },
                loaded: 0,
            }),
            id::BATTERY_STATUS => {
                let b = &self.ac.battery;
                let mut voltages = [u16::MAX; 10];
                voltages[0] = (b.voltage * 1000.0) as u16;
                let charge = match self.fl.battery_failsafe {
                    0 => MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_OK,
                    1 => MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_LOW,
                    _ => MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_CRITICAL,
                };
                MavMessage::BATTERY_STATUS(BATTERY_STATUS_DATA {
                    current_consumed: b.consumed_mah as i32,
                    energy_consumed: (b.consumed_mah * b.voltage * 0.036) as i32,
                    temperature: i16::MAX,
                    voltages,
                    current_battery: (b.current * 100.0) as i16,
                    id: 0,
                    battery_function: MavBatteryFunction::MAV_BATTERY_FUNCTION_UNKNOWN,
                    mavtype: MavBatteryType::MAV_BATTERY_TYPE_UNKNOWN,
                    battery_remaining: self.battery_remaining().round() as i8,
                    time_remaining: 0,
                    charge_state: charge,
                    voltages_ext: [0; 4],
                    mode: MavBatteryMode::MAV_BATTERY_MODE_UNKNOWN,
                    fault_bitmask: MavBatteryFault::empty(),
                })
            }
            id::EKF_STATUS_REPORT => {
                let flags = self.ekf_flags()?;
                let lost = self.has_fault(FaultKind::GpsLoss);
                MavMessage::EKF_STATUS_REPORT(EKF_STATUS_REPORT_DATA {
                    velocity_variance: if lost { 0.9 } else { 0.03 },
                    pos_horiz_variance: if lost { 1.1 } else { 0.1 },
                    pos_vert_variance: 0.005,
                    compass_variance: 0.01,
                    terrain_alt_variance: 0.0,
                    flags: EkfStatusFlags::from_bits_retain(flags),
                    airspeed_variance: 0.06,
                })
            }
            id::VIBRATION => {
                let v = if ac.on_ground { 0.0025 } else { 0.14 };
                MavMessage::VIBRATION(VIBRATION_DATA {
                    time_usec: us,
                    vibration_x: v as f32,
                    vibration_y: v as f32,
                    vibration_z: (v * 4.0) as f32,
                    clipping_0: 0,
                    clipping_1: 0,
                    clipping_2: 0,
                })
            }
            id::RAW_IMU => MavMessage::RAW_IMU(RAW_IMU_DATA {
                time_usec: us,
                xacc: imu_acc.0,
                yacc: imu_acc.1,
                zacc: imu_acc.2,
                xgyro: (ac.roll_rate * 1000.0) as i16,
                ygyro: 0,
                zgyro: (turn_rate * 1000.0) as i16,
                xmag: mag.0,
                ymag: mag.1,
                zmag: mag.2,
                id: 0,
                temperature: 2598,
            }),
            id::SCALED_IMU2 => MavMessage::SCALED_IMU2(SCALED_IMU2_DATA {
                time_boot_ms: ms,
                xacc: imu_acc.0,
                yacc: imu_acc.1,
                zacc: imu_acc.2,
                xgyro: (ac.roll_rate * 1000.0) as i16,
                ygyro: 0,
                zgyro: (turn_rate * 1000.0) as i16,
                xmag: mag.0,
                ymag: mag.1,
                zmag: mag.2,
                temperature: 2598,
            }),
            id::SCALED_IMU3 => MavMessage::SCALED_IMU3(SCALED_IMU3_DATA {
                time_boot_ms: ms,
                xmag: mag.0,
                ymag: mag.1,
                zmag: mag.2,
                ..Default::default()
            }),
            id::SCALED_PRESSURE => MavMessage::SCALED_PRESSURE(SCALED_PRESSURE_DATA {
                time_boot_ms: ms,
                press_abs: pressure_hpa(alt_amsl) as f32,
                press_diff: (q / 100.0) as f32,
                temperature: 2746,
                temperature_press_diff: 0,
            }),
            id::SCALED_PRESSURE2 => MavMessage::SCALED_PRESSURE2(SCALED_PRESSURE2_DATA {
                time_boot_ms: ms,
                press_abs: pressure_hpa(alt_amsl) as f32,
                press_diff: 0.0,
                temperature: 2746,
                temperature_press_diff: 0,
            }),
            id::AIRSPEED => MavMessage::AIRSPEED(AIRSPEED_DATA {
                airspeed: aspd as f32,
                raw_press: q as f32,
                temperature: i16::MAX,
                id: 0,
                flags: AirspeedSensorFlags::AIRSPEED_SENSOR_USING,
            }),
            id::GPS_GLOBAL_ORIGIN => {
                if !self.boot.has(Phase::Origin) {
                    return None;
                }
                let (olat, olon) = self.latlon(V2::ZERO);
                MavMessage::GPS_GLOBAL_ORIGIN(GPS_GLOBAL_ORIGIN_DATA {
                    latitude: olat,
                    longitude: olon,
                    altitude: (self.origin().alt_amsl * 1000.0) as i32,
                    time_usec: us,
                })
            }
            id::EXTENDED_SYS_STATE => {
                use crate::nav_state::Stage;
                let landed = match self.fl.stage {
                    _ if !self.is_flying() => MavLandedState::MAV_LANDED_STATE_ON_GROUND,
                    Stage::TakeoffRoll | Stage::TakeoffClimb => {
                        MavLandedState::MAV_LANDED_STATE_TAKEOFF
                    }
                    Stage::Approach | Stage::Flare | Stage::Rollout { .. } => {
                        MavLandedState::MAV_LANDED_STATE_LANDING
                    }
                    _ => MavLandedState::MAV_LANDED_STATE_IN_AIR,
                };
                MavMessage::EXTENDED_SYS_STATE(EXTENDED_SYS_STATE_DATA {
                    vtol_state: MavVtolState::MAV_VTOL_STATE_UNDEFINED,
                    landed_state: landed,
                })
            }
            id::AUTOPILOT_VERSION => self.autopilot_version(),
            _ => return None,
        })
    }
}

#[cfg(test)]
#[allow(deprecated)] // REQUEST_DATA_STREAM, as ArduPilot's clients still send it
mod tests {
    use crate::vehicle::testing::*;
    use mavlink::dialects::ardupilotmega::*;
    use std::collections::BTreeSet;

    fn names(b: &Bench, from: usize) -> BTreeSet<(&'static str, u8)> {
        b.got[from..]
            .iter()
            .map(|(_, h, m)| (mavlink::Message::message_name(m), h.component_id))
            .collect()
    }

    /// As ArduPlane 4.7 SITL with plane.parm (MAVn_* at 1): every group
    /// at 1 Hz from start-up, unasked.
    #[test]
    fn every_group_at_1_hz_until_asked_otherwise() {
        let mut b = Bench::new(crate::SimConfig {
            boot_servo_burst: false,
            ..crate::SimConfig::default()
        });
        b.run_to(12.0);
        for name in [
            "SYS_STATUS",
            "GPS_RAW_INT",
            "ATTITUDE",
            "VFR_HUD",
            "BATTERY_STATUS",
        ] {
            let n = b.of(name).len();
            // From 2 s (ready at 1.74 s) to 12 s.
            assert!((10..=11).contains(&n), "{n} {name} in 12 s");
        }
        assert!(b.of("MISSION_ITEM_REACHED").is_empty(), "in no group");
        let mav1 = b.v.params.get("MAV1_EXTRA1");
        assert_eq!(mav1, 1.0);
    }

    /// With MAVn_* at 0: nothing but what ArduPlane sends unasked.
    #[test]
    fn nothing_is_streamed_until_asked() {
        let mut b = Bench::new(crate::SimConfig {
            boot_servo_burst: false,
            stream_hz: 0,
            ..quick()
        });
        b.run_to(12.0);
        let unasked: BTreeSet<(&str, u8)> = [
            ("HEARTBEAT", 1),
            ("HEARTBEAT", 100),
            ("STATUSTEXT", 1),
            ("HOME_POSITION", 1),
            ("GPS_GLOBAL_ORIGIN", 1),
            ("PARAM_VALUE", 1),
            ("TIMESYNC", 1),
        ]
        .into_iter()
        .collect();
        assert_eq!(names(&b, 0), unasked);
        // One message at 10 Hz: that one, and nothing else.
        let r = b.command(
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            [30.0, 100_000.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        assert_eq!(r, Some(MavResult::MAV_RESULT_ACCEPTED));
        let from = b.got.len();
        b.run_to(17.0);
        let att = b.since(from, "ATTITUDE");
        assert!(
            (49..=51).contains(&att.len()),
            "{} ATTITUDE in 5 s",
            att.len()
        );
        let streamed: BTreeSet<&str> = names(&b, from)
            .into_iter()
            .map(|(n, _)| n)
            .filter(|n| !["HEARTBEAT", "STATUSTEXT", "PARAM_VALUE", "TIMESYNC"].contains(n))
            .collect();
        assert_eq!(streamed, ["ATTITUDE"].into_iter().collect());
        // A message the vehicle cannot send: DENIED, with ArduPilot's text.
        let r = b.command(
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            [12_345.0, 100_000.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        assert_eq!(r, Some(MavResult::MAV_RESULT_DENIED));
        assert_eq!(
            b.texts().last().unwrap(),
            "No ap_message for mavlink id (12345)"
        );
        // A stream group at 2 Hz, in sim time.
        b.send(MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
            req_message_rate: 2,
            target_system: 1,
            target_component: 1,
            req_stream_id: MavDataStream::MAV_DATA_STREAM_EXTRA2,
            start_stop: 1,
        }));
        let from = b.got.len();
        b.run_to(27.0);
        let hud = b.since(from, "VFR_HUD");
        assert!(
            (19..=21).contains(&hud.len()),
            "{} VFR_HUD in 10 s",
            hud.len()
        );
        let mav1 = b.since(from - 1, "PARAM_VALUE");
        assert!(mav1.iter().any(|(_, _, m)| matches!(m,
            MavMessage::PARAM_VALUE(p) if p.param_id.to_str() == Ok("MAV1_EXTRA2") && p.param_value == 2.0)));
        // Stopped again.
        assert_eq!(
            b.command(
                MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
                [30.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0]
            ),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        let from = b.got.len();
        b.run_to(30.0);
        assert!(b.since(from, "ATTITUDE").is_empty());
    }

    #[test]
    fn heartbeat_as_arduplane_and_the_boot_burst() {
        let mut b = Bench::new(crate::SimConfig {
            stream_hz: 0,
            ..crate::SimConfig::default()
        });
        b.run_to(3.0);
        // While INITIALISING: SERVO_OUTPUT_RAW at 50 Hz, all zero, unasked.
        let servo = b.of("SERVO_OUTPUT_RAW");
        assert!((80..=90).contains(&servo.len()), "{}", servo.len());
        assert!(servo
            .iter()
            .all(|m| matches!(m, MavMessage::SERVO_OUTPUT_RAW(s) if s.servo3_raw == 0)));
        let hb: Vec<(u64, HEARTBEAT_DATA)> = b
            .got
            .iter()
            .filter_map(|(t, h, m)| match m {
                MavMessage::HEARTBEAT(x) if h.component_id == 1 => Some((*t, x.clone())),
                _ => None,
            })
            .collect();
        // 1 s: INITIALISING; 1.74 s: MANUAL (sent at once); 2 s: the cadence.
        assert_eq!(hb[0].1.custom_mode, crate::modes::INITIALISING);
        assert_eq!(hb[0].1.system_status, MavState::MAV_STATE_CALIBRATING);
        assert_eq!(hb[0].1.base_mode.bits(), 17);
        assert_eq!(hb[1].1.custom_mode, crate::modes::MANUAL);
        assert_eq!(hb[1].1.base_mode.bits(), 81);
        assert_eq!(hb[1].1.system_status, MavState::MAV_STATE_STANDBY);
        assert_eq!(hb[1].1.mavtype, MavType::MAV_TYPE_FIXED_WING);
        assert_eq!(hb[1].1.autopilot, MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA);
        assert_eq!(
            hb.iter().map(|x| x.0 / 10_000).collect::<Vec<_>>(),
            vec![100, 174, 200, 300]
        );
    }

    /// SET_MESSAGE_INTERVAL as ArduPlane 4.7 SITL answered a gateway (see
    /// the README): events and a radio's messages DENIED, each with its
    /// text; HEARTBEAT at the interval asked, −1 stopping it but for mode
    /// changes.
    #[test]
    fn interval_requests_denied_and_heartbeat_as_arduplane() {
        let mut b = Bench::new(quick());
        b.run_to(2.0);
        let ask = |b: &mut Bench, m: u32, us: f32| {
            b.command(
                MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
                [m as f32, us, 0.0, 0.0, 0.0, 0.0, 0.0],
            )
        };
        for m in [77, 253, 109, 166, 47] {
            assert_eq!(
                ask(&mut b, m, 250_000.0),
                Some(MavResult::MAV_RESULT_DENIED)
            );
            assert_eq!(
                b.texts().last().unwrap(),
                &format!("No ap_message for mavlink id ({m})")
            );
        }
        let beats = |b: &Bench, from: usize| {
            b.since(from, "HEARTBEAT")
                .into_iter()
                .filter(|(_, h, _)| h.component_id == 1)
                .count()
        };
        assert_eq!(
            ask(&mut b, 0, 250_000.0),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        let from = b.got.len();
        b.run_to(7.0);
        assert!((19..=21).contains(&beats(&b, from)), "{}", beats(&b, from));
        assert_eq!(ask(&mut b, 0, -1.0), Some(MavResult::MAV_RESULT_ACCEPTED));
        let from = b.got.len();
        b.run_to(12.0);
        assert_eq!(beats(&b, from), 0);
        assert_eq!(
            b.set_mode(crate::modes::FBWA),
            Some(MavResult::MAV_RESULT_ACCEPTED)
        );
        assert_eq!(beats(&b, from), 1, "a mode change still says so");
    }

    /// SYS_STATUS's bits as ArduPlane 4.7 SITL sets them (see the README):
    /// the AHRS enabled and healthy once the EKF is active, whatever the
    /// mode; logging enabled while armed; no extended bits.
    #[test]
    fn sys_status_bits_as_arduplane() {
        let mut b = Bench::new(crate::SimConfig {
            first_arm_refused: false,
            ..crate::SimConfig::default()
        });
        let bits = |b: &Bench| match b.of("SYS_STATUS").last() {
            Some(MavMessage::SYS_STATUS(s)) => (
                s.onboard_control_sensors_enabled.bits(),
                s.onboard_control_sensors_health.bits(),
                s.onboard_control_sensors_present_extended.bits(),
            ),
            _ => panic!("no SYS_STATUS"),
        };
        const AHRS: u32 = 0x20_0000;
        const LOGGING: u32 = 0x100_0000;
        b.run_to(15.0);
        let (enabled, health, extended) = bits(&b);
        assert_eq!((enabled & AHRS, health & AHRS, extended), (0, 0, 0));
        b.run_to(22.0); // the EKF active at 20.5 s
        let (enabled, health, _) = bits(&b);
        assert_eq!(
            (enabled & AHRS, health & AHRS, enabled & LOGGING),
            (AHRS, AHRS, 0)
        );
        assert_eq!(b.arm(), Some(MavResult::MAV_RESULT_ACCEPTED));
        b.run_to(23.5);
        assert_eq!(bits(&b).0 & LOGGING, LOGGING);
    }
}
