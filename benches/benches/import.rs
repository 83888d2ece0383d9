//! URDF import: the report's arm as `chessarm urdf` writes it, and the same arm with 10 000 and
//! 100 000 fixed marker links after the tool (the import was once quadratic in them, 109 s
//! for 100 000; linear, the two sizes differ by ten times).

use chessarm::app::setup::file::Setup;
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

/// The report's arm as URDF with `extra` fixed links chained after its tool link.
fn with_fixed_links(extra: usize) -> String {
    let setup = Setup::default();
    let text = chessarm::app::formats::urdf::to_urdf(
        &setup.arm,
        "chessarm",
        &setup.joint_names,
        &[1.0; 4],
        setup.clearance.gripper.palm_depth(),
    );
    let mut chain = String::new();
    let mut parent = "tool".to_string();
    for i in 0..extra {
        chain.push_str(&format!(
            "<link name=\"m{i}\"/><joint name=\"jm{i}\" type=\"fixed\"><parent link=\"{parent}\"/><child link=\"m{i}\"/></joint>\n"
        ));
        parent = format!("m{i}");
    }
    text.replace("</robot>", &format!("{chain}</robot>"))
}

fn import(c: &mut Criterion) {
    let mut group = c.benchmark_group("urdf import");
    group.sample_size(10);
    for extra in [0, 10_000, 100_000] {
        let text = with_fixed_links(extra);
        chessarm::app::setup::urdf_import::from_urdf(&text, &Default::default()).expect("the arm loads");
        group.bench_function(format!("{extra} fixed links after the tool ({} kB)", text.len() / 1000), |b| {
            b.iter(|| chessarm::app::setup::urdf_import::from_urdf(black_box(&text), &Default::default()))
        });
    }
    group.finish();
}

criterion_group!(benches, import);
criterion_main!(benches);
