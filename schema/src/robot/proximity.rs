//! Messages of the proximity server (PServer, §4.6.2): sonar and infrared
//! replies, the sonar range setting, and the scan stream.

use super::{exactly_sonars, SONARS};
use serde::{Deserialize, Serialize};

/// `sonar`: the 24 ranges, mm (sonar 12 looks forward, 6 right, 18 left).
///
/// ```text
/// {"sonar_mm":[10000,2620,…],"time_ms":120400}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SonarReply {
    /// 24 ranges, mm; the sensor's maximum when nothing echoed.
    #[serde(deserialize_with = "exactly_sonars")]
    pub sonar_mm: Vec<u32>,
    /// When the ring fired, device ms.
    pub time_ms: u64,
}

/// `ir`: 24 detector slots (8 fitted), 1 = something within range.
///
/// ```text
/// {"ir":[0,0,1,0,…],"time_ms":120400}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IrReply {
    /// 24 values, 0 or 1.
    #[serde(deserialize_with = "exactly_sonars")]
    pub ir: Vec<u8>,
    /// When the detectors were read, device ms.
    pub time_ms: u64,
}

/// `timeout`: per-sensor maximum range, mm (one number sets all 24).
///
/// ```text
/// {"max_mm":5000}        or        {"max_mm":[5000,5000,…]}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SetTimeout {
    /// One range for all sensors, or 24.
    pub max_mm: MaxRange,
}

/// One maximum range for every sonar, or one each.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum MaxRange {
    /// The same for all 24.
    All(u32),
    /// One per sonar.
    Each(Vec<u32>),
}

/// Reply to `timeout`: the ranges now in force.
///
/// ```text
/// {"max_mm":[5000,5000,…]}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeoutReply {
    /// 24 maximum ranges, mm.
    #[serde(deserialize_with = "exactly_sonars")]
    pub max_mm: Vec<u32>,
}

/// `scan`: published by the proximity server for each new scan.
///
/// ```text
/// {"robot":"r1","seq":312,"time_ms":31200,"sonar_mm":[…24],"ir":[…24]}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scan {
    /// The robot.
    pub robot: String,
    /// Scans published so far by this server (a gap means a lost scan).
    pub seq: u64,
    /// When the ring fired, device ms.
    pub time_ms: u64,
    /// 24 ranges, mm.
    #[serde(deserialize_with = "exactly_sonars")]
    pub sonar_mm: Vec<u32>,
    /// 24 infrared values, 0 or 1.
    #[serde(deserialize_with = "exactly_sonars")]
    pub ir: Vec<u8>,
}

impl Scan {
    /// The infrared detectors' bits (bit `i` for slot `i`) as the thesis'
    /// 24 slots of 0 or 1: what a device reads, as `ir` carries it.
    pub fn ir_slots(bits: u32) -> Vec<u8> {
        (0..SONARS).map(|i| ((bits >> i) & 1) as u8).collect()
    }

    /// Whether infrared slot `i` sees something: a slot the scan does not
    /// have sees nothing.
    pub fn ir_lit(&self, i: usize) -> bool {
        self.ir.get(i).is_some_and(|b| *b != 0)
    }
}
