//! `reset` returns a controller to the state right after construction: the same measurements give the
//! same commands, bit for bit, as a fresh controller's.

use millcomp_runtime::{Command, Controller, ControllerKind, Measurement};

use crate::common;

/// 3 000 closed-loop steps of `ctl` on a fresh machine: its commands and the readings it got.
fn run(ctl: &mut Controller, kind: ControllerKind) -> (Vec<Command>, Vec<Measurement>) {
    let p = common::program(kind);
    let mut stage = common::machine(&p, ctl.period_s());
    let mut m = Measurement::NONE;
    let (mut commands, mut readings) = (Vec::new(), Vec::new());
    for _ in 0..3_000 {
        readings.push(m);
        let c = ctl.step(&m);
        commands.push(c);
        m = common::reading(&stage.step(c.voltage_v));
    }
    (commands, readings)
}

fn bits(c: &[Command]) -> Vec<(u64, u32, u32)> {
    c.iter()
        .map(|c| (c.voltage_v.to_bits(), c.flags, c.iterations))
        .collect()
}

#[test]
fn a_reset_controller_gives_a_fresh_ones_commands() {
    for kind in ControllerKind::ALL {
        for compensated in [false, true] {
            let mut fresh = common::controller(kind, compensated);
            let (first, readings) = run(&mut fresh, kind);
            // the same controller after a reset, fed the same readings, without the machine
            fresh.reset().unwrap();
            assert_eq!(fresh.cycle(), 0);
            let again: Vec<Command> = readings.iter().map(|m| fresh.step(m)).collect();
            assert_eq!(
                bits(&first),
                bits(&again),
                "{kind} (compensated: {compensated})"
            );
            // a fault injected before the reset is gone after it
            fresh.inject_solver_failures(5);
            fresh.reset().unwrap();
            let third: Vec<Command> = readings.iter().map(|m| fresh.step(m)).collect();
            assert_eq!(bits(&first), bits(&third), "{kind} after an injected fault");
        }
    }
}
