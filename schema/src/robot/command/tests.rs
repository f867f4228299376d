use super::*;
use crate::robot::{MaxRange, READS};

/// Sends `command`'s payload as the client does and parses it as the
/// server does.
fn round_trip<C: Payload + PartialEq + std::fmt::Debug>(command: C) {
    let payload = command.payload();
    let parsed: C =
        parse_payload(payload.as_deref()).unwrap_or_else(|e| panic!("{}: {e}", C::NAME));
    assert_eq!(parsed, command, "{}", C::NAME);
}

#[test]
fn every_payload_parses_back_as_it_was_encoded() {
    round_trip(Move {
        distance_mm: -2000.5,
        velocity_mm_s: 300.0,
        accel_mm_s2: -1.0,
    });
    round_trip(Turn {
        degrees: 90.0,
        velocity_deg_s: -1.0,
        accel_deg_s2: 40.0,
    });
    round_trip(Go {
        velocity_mm_s: -400.0,
    });
    round_trip(Jog { rate_deg_s: -4.0 });
    round_trip(Stop { emergency: true });
    round_trip(SetPose {
        x_mm: i64::from(i32::MAX),
        y_mm: -7,
        heading_deg: 270.0,
    });
    round_trip(AdjustPose {
        dx_mm: -120,
        dy_mm: 0,
        dheading_deg: 1.5,
    });
    round_trip(SetBumper { watch: false });
    round_trip(SetTimeout {
        max_mm: MaxRange::Each(vec![5000; 24]),
    });
    round_trip(SetTimeout {
        max_mm: MaxRange::All(3000),
    });
}

#[test]
fn the_examples_shown_in_errors_are_accepted() {
    fn accepted<C: Payload>() {
        parse_payload::<C>(Some(C::EXAMPLE.as_bytes()))
            .unwrap_or_else(|e| panic!("{}: {e}", C::NAME));
    }
    accepted::<Move>();
    accepted::<Turn>();
    accepted::<Go>();
    accepted::<Jog>();
    accepted::<Stop>();
    accepted::<SetPose>();
    accepted::<AdjustPose>();
    accepted::<SetBumper>();
    accepted::<SetTimeout>();
}

#[test]
fn a_bad_payload_names_the_command_and_shows_an_example() {
    let e = parse_payload::<Move>(None).unwrap_err();
    assert_eq!(e.code, ErrorCode::BadJson);
    assert!(
        e.message.contains("'move'") && e.message.contains("distance_mm"),
        "{e}"
    );
    let e = parse_payload::<Go>(Some(br#"{"velocity_mm_s":"fast"}"#)).unwrap_err();
    assert_eq!(e.code, ErrorCode::WrongType);
    let e = parse_payload::<Turn>(Some(br#"{"degrees":1e999}"#)).unwrap_err();
    assert!(
        matches!(e.code, ErrorCode::OutOfRange | ErrorCode::BadJson),
        "{e}"
    );
}

#[test]
fn what_only_reads_is_in_the_read_list_and_what_acts_is_not() {
    for name in [
        ReadPose::NAME,
        ReadBumper::NAME,
        ReadSpeed::NAME,
        ReadWheelSpeed::NAME,
        ReadMode::NAME,
        ReadSonar::NAME,
        ReadIr::NAME,
        ReadSize::NAME,
        Rows::NAME,
    ] {
        assert!(READS.contains(&name), "{name} reads");
    }
    for (name, acts) in [
        (Move::NAME, Move::ACTS),
        (Turn::NAME, Turn::ACTS),
        (Go::NAME, Go::ACTS),
        (Jog::NAME, Jog::ACTS),
        (Stop::NAME, Stop::ACTS),
        (SetPose::NAME, SetPose::ACTS),
        (AdjustPose::NAME, AdjustPose::ACTS),
        (SetBumper::NAME, SetBumper::ACTS),
        (SetTimeout::NAME, SetTimeout::ACTS),
        // A grab takes a new picture, and a lock changes who may act:
        // neither is a read, and neither is repeated on silence.
        (Grab::NAME, Grab::ACTS),
        (TakeLock::NAME, TakeLock::ACTS),
        (ReleaseLock::NAME, ReleaseLock::ACTS),
    ] {
        assert!(!READS.contains(&name), "{name} is no read");
        let kept_apart = ["grab", "lock", "unlock"].contains(&name);
        assert_eq!(acts, !kept_apart, "{name}");
    }
}

#[test]
fn parameters_parse_back() {
    for png in [false, true] {
        let grab = Grab { png };
        let text: Vec<String> = grab
            .params()
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect();
        assert_eq!(
            Grab::parse(&mut Params::parse(&text.join(";"))).unwrap(),
            grab
        );
    }
    let lock = TakeLock {
        owner: Some("c7-r1".into()),
        ttl_ms: Some(2500),
        renew: Some(17),
    };
    let text: Vec<String> = lock
        .params()
        .iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect();
    let mut params = Params::parse(&text.join(";"));
    let meta = crate::robot::Meta::take(&mut params).unwrap();
    assert_eq!(TakeLock::parse(&mut params, meta.fence).unwrap(), lock);
    params.finish("lock", &[]).unwrap();
    let rows = Rows {
        rows: vec![120, 200, 201, 202, 360],
    };
    let (k, v) = &rows.params()[0];
    assert_eq!(*k, param::ROWS);
    assert_eq!(crate::robot::parse_rows(v, 64).unwrap(), rows.rows);
}
