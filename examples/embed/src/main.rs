//! Runs the three embedded scenes for 2 s each and prints what happened.

use std::process::ExitCode;

fn main() -> ExitCode {
    let outcomes = match mbdc_example_embed::run_all(2.0) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let mut ok = true;
    for o in &outcomes {
        let (e0, e1) = (o.energy[0], *o.energy.last().unwrap_or(&o.energy[0]));
        println!(
            "{:<20} {} steps to t = {:.3} s, energy {:.6} → {:.6} J, max violation {:.2e}",
            o.name, o.report.steps, o.report.t_end, e0, e1, o.report.max_violation.0
        );
        ok &= o.report.finished;
    }
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
