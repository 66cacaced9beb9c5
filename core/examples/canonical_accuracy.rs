//! The canonicalization accuracy table of docs/canonicalization.md: per outfit, the median
//! error of canonicalized depth points against their true canonical positions.
//!
//! cargo run --release -p avatar-core --example canonical_accuracy

use avatar_core::canonical::{FieldOptions, report::accuracy};
use avatar_core::synth::ALL_OUTFITS;

fn main() {
    let body = avatar_core::body::open_body_ref();
    println!(
        "| outfit | loose | points | median error (mm) | 90th pct (mm) | dropped by the 2 cm filter | no root | seconds |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for outfit in ALL_OUTFITS {
        let r = accuracy(body, outfit, "walk", 8, 101, &FieldOptions::default())
            .expect("synthetic capture");
        println!(
            "| {} | {} | {} | {:.2} | {:.2} | {:.2}% | {:.2}% | {:.2} |",
            outfit.name(),
            if outfit.is_loose() { "yes" } else { "no" },
            r.points,
            r.median_mm,
            r.p90_mm,
            r.dropped_fraction * 100.0,
            r.unsolved_fraction * 100.0,
            r.seconds
        );
    }
}
