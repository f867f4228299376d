//! The garbage `rome fuzz` sends: parameters and payloads, picked from a
//! seeded generator.

use rome_sim::rng::Rng;

/// A number below `n`, from `rng`.
pub fn pick(rng: &mut Rng, n: usize) -> usize {
    (rng.next_u64() % n.max(1) as u64) as usize
}

const PARAM_NAMES: &[&str] = &[
    "priority",
    "fence",
    "wait_ms",
    "client",
    "op",
    "rows",
    "back",
    "len",
    "value",
    "ticket",
    "owner",
    "hold_ms",
    "undo",
    "format",
    "hold_s",
    "emergency",
    "x",
    "bak",
    "_zenoh",
    "",
];

/// A query's parameters: known and unknown names, values of every
/// kind that is out of range.
pub fn params(rng: &mut Rng) -> String {
    let values = [
        String::new(),
        "-1".into(),
        "0".into(),
        "1".into(),
        "255".into(),
        "256".into(),
        "4294967296".into(),
        "18446744073709551616".into(),
        "1e309".into(),
        "NaN".into(),
        "true".into(),
        "abc".into(),
        "0-4095,0-4095,0-4095,0-4095,0-4095".into(),
        "0-4294967295".into(),
        "9".repeat(10_000),
        "%ff%00".into(),
        "a=b=c".into(),
    ];
    let n = pick(rng, 5);
    (0..n)
        .map(|_| {
            let name = PARAM_NAMES[pick(rng, PARAM_NAMES.len())];
            let value = &values[pick(rng, values.len())];
            if pick(rng, 10) == 0 {
                name.to_string()
            } else {
                format!("{name}={value}")
            }
        })
        .collect::<Vec<_>>()
        .join(if pick(rng, 10) == 0 { "&" } else { ";" })
}

/// A payload, and what kind it is.
pub fn payload(rng: &mut Rng) -> (&'static str, Option<Vec<u8>>) {
    let numbers = [
        "0",
        "-1",
        "1e309",
        "-1e309",
        "4294967296",
        "18446744073709551616",
        "1.5",
        "null",
        "\"7\"",
        "[]",
        "{}",
    ];
    let num = |rng: &mut Rng| numbers[pick(rng, numbers.len())];
    match pick(rng, 10) {
        0 => ("none", None),
        1 => {
            let n = pick(rng, 300);
            (
                "bytes",
                Some((0..n).map(|_| (rng.next_u64() & 0xff) as u8).collect()),
            )
        }
        2 => ("not-utf8", Some(vec![b'{', 0xff, 0xfe, b'}'])),
        3 => {
            let depth = 1 + pick(rng, 20_000);
            let mut s = "[".repeat(depth);
            s.push_str(&"]".repeat(depth));
            ("deep", Some(s.into_bytes()))
        }
        4 => (
            "huge-string",
            Some(format!("\"{}\"", "a".repeat(1 << 20)).into_bytes()),
        ),
        5 => {
            let (a, b, c) = (num(rng), num(rng), num(rng));
            let msgs = [
                format!("{{\"distance_mm\":{a},\"velocity_mm_s\":{b},\"accel_mm_s2\":{c}}}"),
                format!("{{\"x_mm\":{a},\"y_mm\":{b},\"heading_deg\":{c}}}"),
                format!("{{\"velocity_mm_s\":{a}}}"),
                format!("{{\"rate_deg_s\":{a}}}"),
                format!("{{\"degrees\":{a},\"velocity_deg_s\":{b}}}"),
                format!("{{\"hold_ms\":{a},\"priority\":{b}}}"),
                format!("{{\"sonar\":{a},\"timeout_mm\":{b}}}"),
                format!("{{\"value\":{a}}}"),
            ];
            (
                "wrong-numbers",
                Some(msgs[pick(rng, msgs.len())].clone().into_bytes()),
            )
        }
        6 => {
            let scans = [
                "{\"robot\":\"r1\",\"seq\":1,\"time_ms\":5,\"sonar_mm\":[1,2,3],\"ir\":[0]}"
                    .to_string(),
                format!(
                    "{{\"robot\":\"r1\",\"seq\":{},\"time_ms\":{},\"sonar_mm\":[{}],\"ir\":[{}]}}",
                    num(rng),
                    num(rng),
                    vec!["4294967295"; 24].join(","),
                    vec!["7"; 24].join(",")
                ),
                "{\"robot\":\"r1\",\"frame\":1,\"time_ms\":1,\"camera\":\"up\",\"width\":4294967295,\"height\":4294967295}".to_string(),
                format!("{{\"robot\":\"r1\",\"time_ms\":{},\"x_mm\":{},\"y_mm\":{},\"heading_deg\":{}}}", num(rng), num(rng), num(rng), num(rng)),
                "{\"holder\":\"x\",\"fence\":18446744073709551615,\"expires_ms\":-5}".to_string(),
            ];
            (
                "stream-shaped",
                Some(scans[pick(rng, scans.len())].clone().into_bytes()),
            )
        }
        7 => ("wrong-type", Some(num(rng).as_bytes().to_vec())),
        8 => (
            "extra-fields",
            Some(br#"{"velocity_mm_s":100,"x":1,"__proto__":{}}"#.to_vec()),
        ),
        _ => ("empty", Some(Vec::new())),
    }
}
