//! The numerical-stability suite (`voxkit::stability`): one test per case.
//! The quick tier runs by default (CI); the long tier is `#[ignore]`d:
//! `cargo test --release --test stability -- --include-ignored`.

use voxkit::stability::{Tier, cases, run_case};

fn run(name: &str, tier: Tier) {
    let case = cases()
        .into_iter()
        .find(|c| c.name == name)
        .unwrap_or_else(|| panic!("no stability case {name}"));
    let r = run_case(&case, tier);
    println!(
        "{} [{}] {:.2} s\n  expected: {}\n  observed: {}",
        r.name,
        tier.name(),
        r.seconds,
        r.expectation,
        r.observed
    );
    assert!(
        r.passed,
        "{name} ({}): expected {}; observed {}",
        tier.name(),
        r.expectation,
        r.observed
    );
}

macro_rules! stability_cases {
    ($($name:ident),* $(,)?) => {
        mod quick {
            $(#[test] fn $name() { super::run(stringify!($name), super::Tier::Quick); })*
        }
        mod long {
            $(#[test] #[ignore = "long tier: cargo test --release --test stability -- --include-ignored"]
              fn $name() { super::run(stringify!($name), super::Tier::Long); })*
        }
        /// Every case of the library has a test here.
        #[test]
        fn every_case_has_a_test() {
            let listed = [$(stringify!($name)),*];
            for c in cases() {
                assert!(listed.contains(&c.name), "case {} has no test", c.name);
            }
            assert_eq!(listed.len(), cases().len());
        }
    };
}

stability_cases!(
    line_endpoints_at_range_ends,
    line_spans_at_i64_i128_switch,
    out_of_range_inputs_are_typed_errors,
    tripod_ties_one_unit_away,
    line26_ties_one_unit_away,
    triangle_index_at_range_ends,
    kernel_i64_i128_switch,
    sliver_and_needle_triangles,
    closed_mesh_with_slivers,
    damaged_meshes_surface,
    damaged_meshes_solid,
    spot_scaled_and_offset,
    amanatides_woo_long_rays,
    render_grazing_segments,
    render_grazing_images,
);
