//! Every decoder of network input (`rome_tests::decoders`) fed valid
//! inputs and thousands of seeded mutations of them (bit flips, bytes
//! inserted and removed, truncations, splices, numbers swapped for
//! extreme ones): none may panic. The same decoders are the `cargo fuzz`
//! targets in `fuzz/`, for long runs.

use rome_sim::rng::Rng;
use rome_tests::decoders;

/// Valid inputs for each decoder, the mutations' starting points.
fn seeds(decoder: &str) -> Vec<Vec<u8>> {
    let text: Vec<String> = match decoder {
        "data_request" => vec![
            "rome/data/set/PosX\nop=a1\n4".into(),
            "rome/data/set/r1/Pose\n\n{\"x_mm\":1200,\"heading_deg\":90}".into(),
            "rome/data/var/PosX\nback=2\n".into(),
            "rome/data/history/PosX\nlen=5\n".into(),
            "rome/data/create/S\nvalue=3\n".into(),
            "rome/data/sem/S\n\n".into(),
            "rome/data/signal/S\nop=b2;owner=o1;undo=true\n".into(),
            "rome/data/try-wait/S\nop=c3\n".into(),
            "rome/data/wait/S\nticket=t1;owner=o1;hold_ms=10;undo=true\n".into(),
            "rome/data/cancel/S\nticket=t1\n".into(),
            "rome/data/ack/S\nticket=t1\n".into(),
        ],
        "robot_command" => vec![
            "rome/robot/r1/base/move\npriority=200;fence=3\n{\"distance_mm\":1000,\"velocity_mm_s\":300,\"accel_mm_s2\":300}".into(),
            "rome/robot/r1/base/turn\n\n{\"degrees\":90,\"velocity_deg_s\":45,\"accel_deg_s2\":-1}".into(),
            "rome/robot/r1/base/go\n\n{\"velocity_mm_s\":300}".into(),
            "rome/robot/r1/base/jog\n\n{\"rate_deg_s\":10}".into(),
            "rome/robot/r1/base/set-pose\n\n{\"x_mm\":0,\"y_mm\":0,\"heading_deg\":90}".into(),
            "rome/robot/r1/base/lock\nhold_s=30;client=c1\n".into(),
            "rome/robot/r1/base/pose\nwait_ms=50\n".into(),
            "rome/robot/r1/proximity/timeout\n\n{\"max_mm\":5000}".into(),
            "rome/robot/r1/proximity/sonar\npriority=1\n".into(),
            "rome/robot/r1/camera/up/rows\nrows=120,200-263,360\n".into(),
            "rome/robot/r1/camera/up/grab\nformat=png\n".into(),
        ],
        "messages" => vec![
            format!(
                "{{\"robot\":\"r1\",\"seq\":3,\"time_ms\":1500,\"sonar_mm\":[{}],\"ir\":[{}]}}",
                vec!["1200"; 24].join(","),
                vec!["0"; 24].join(",")
            ),
            "{\"robot\":\"r1\",\"camera\":\"up\",\"frame\":31,\"time_ms\":15500,\"width\":512,\"height\":482}".into(),
            "{\"width\":512,\"height\":482}".into(),
            "{\"code\":\"bad_json\",\"message\":\"x\"}".into(),
            "{\"name\":\"GoalData\",\"ticket\":\"t\",\"status\":\"pending\",\"position\":2}".into(),
            "{\"robot\":\"r1\",\"time_ms\":61500,\"x_mm\":-4210.5,\"y_mm\":10480.2,\"heading_deg\":90.4,\"travelled_mm\":30125.0,\"contacts\":{\"wall\":0,\"robot\":0,\"bumper\":0}}".into(),
            "{\"goal_type\":\"L\",\"distance\":3,\"direction_deg\":90.0}".into(),
        ],
        "image_schema" => vec![
            "gray8 width=512 height=482 frame=31 time_ms=15500 rows=120,241,360".into(),
            "gray8 width=512 height=482 frame=31 time_ms=15500".into(),
            "120,200-263,360".into(),
        ],
        "stickrep" => vec![std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../maps/data/fig5_3.stk"
        ))
        .unwrap_or_else(|e| panic!("fig5_3.stk: {e}"))],
        "serial" => {
            use rome_hardware::serial::proto::{command_int, frame, Sip};
            let sip = frame(&Sip::default().encode());
            let mut two = sip.clone();
            two.extend_from_slice(&command_int(11, -300));
            return vec![sip, two];
        }
        other => panic!("no seeds for {other}"),
    };
    text.into_iter().map(String::into_bytes).collect()
}

const EXTREMES: &[&[u8]] = &[
    b"-1",
    b"0",
    b"4294967296",
    b"18446744073709551616",
    b"1e309",
    b"NaN",
    b"-0",
    b"99999999999999999999999999999",
    b"\"\"",
    b"null",
    b"[]",
];

/// One mutation of `input`, using `other` for splices.
fn mutate(rng: &mut Rng, input: &[u8], other: &[u8]) -> Vec<u8> {
    let mut v = input.to_vec();
    let at = |rng: &mut Rng, len: usize| (rng.next_u64() % (len as u64 + 1)) as usize;
    for _ in 0..1 + rng.next_u64() % 4 {
        match rng.next_u64() % 7 {
            0 if !v.is_empty() => {
                let i = at(rng, v.len() - 1);
                v[i] ^= 1 << (rng.next_u64() % 8);
            }
            1 => {
                let i = at(rng, v.len());
                v.insert(i, (rng.next_u64() & 0xff) as u8);
            }
            2 if !v.is_empty() => {
                let i = at(rng, v.len() - 1);
                v.remove(i);
            }
            3 => {
                let i = at(rng, v.len());
                v.truncate(i);
            }
            4 => {
                let (i, j) = (at(rng, v.len()), at(rng, other.len()));
                v.truncate(i);
                v.extend_from_slice(&other[j..]);
            }
            5 => {
                // A number swapped for an extreme one.
                if let Some(i) = v.iter().position(|b| b.is_ascii_digit()) {
                    let end = v[i..]
                        .iter()
                        .position(|b| !b.is_ascii_digit())
                        .map_or(v.len(), |k| i + k);
                    let e = EXTREMES[(rng.next_u64() % EXTREMES.len() as u64) as usize];
                    v.splice(i..end, e.iter().copied());
                }
            }
            _ => {
                let i = at(rng, v.len());
                let j = at(rng, v.len());
                let (a, b) = (i.min(j), i.max(j));
                let piece = v[a..b].to_vec();
                v.splice(b..b, piece);
            }
        }
    }
    v
}

fn run(name: &str, decoder: decoders::Decoder, cases: usize) {
    let seeds = seeds(name);
    let mut rng = Rng::new(0xF022 ^ name.len() as u64);
    for s in &seeds {
        decoder(s);
    }
    let mut input = seeds[0].clone();
    for n in 0..cases {
        // Mostly grow from the last input, sometimes start again from a seed.
        if n % 16 == 0 {
            input = seeds[n / 16 % seeds.len()].clone();
        }
        let other = &seeds[(rng.next_u64() % seeds.len() as u64) as usize];
        input = mutate(&mut rng, &input, other);
        if input.len() > 1 << 16 {
            input.truncate(1 << 16);
        }
        let shown = input.clone();
        if std::panic::catch_unwind(|| decoder(&shown)).is_err() {
            panic!(
                "decoder {name} panicked on case {n}: {:?}",
                String::from_utf8_lossy(&input)
            );
        }
    }
}

#[test]
fn no_decoder_panics_on_mutated_input() {
    for (name, decoder) in decoders::ALL {
        let cases = if *name == "stickrep" { 5_000 } else { 100_000 };
        run(name, *decoder, cases);
    }
}
