//! The test helper `common::require`: a test that would skip for a missing
//! device feature, data file or tool fails when `CI` is set, and skips with a
//! message otherwise.

mod common;
use common::*;
use std::process::Command;

#[test]
fn available_never_skips() {
    assert!(require_in_ci(false, true, "x"));
    assert!(require_in_ci(true, true, "x"));
}

#[test]
fn missing_skips_outside_ci() {
    assert!(!require_in_ci(false, false, "a feature"));
}

#[test]
#[should_panic(expected = "CI is set but a feature is not available")]
fn missing_fails_under_ci() {
    require_in_ci(true, false, "a feature");
}

/// Not run on its own (ignored): the subject of the next test, which runs it
/// in a child process of this test binary with and without `CI`.
#[test]
#[ignore]
fn a_test_that_needs_something_missing() {
    if !require(false, "something missing") {
        return;
    }
    unreachable!("require(false, ..) returned true");
}

/// `require` reads `CI` from the environment: the same test passes (with a
/// skip message) without it and fails with it.
#[test]
fn require_reads_ci_from_the_environment() {
    let run = |ci: Option<&str>| {
        let mut c = Command::new(std::env::current_exe().unwrap());
        c.args([
            "--ignored",
            "--exact",
            "a_test_that_needs_something_missing",
            "--nocapture",
            "--test-threads=1",
        ]);
        c.env_remove("CI");
        if let Some(v) = ci {
            c.env("CI", v);
        }
        let o = c.output().unwrap();
        (
            o.status.success(),
            String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr),
        )
    };
    let (ok, out) = run(None);
    assert!(ok, "without CI the test skips and passes:\n{out}");
    assert!(
        out.contains("skipped: something missing not available"),
        "{out}"
    );
    assert!(out.contains("1 passed"), "{out}");
    for v in ["1", "true"] {
        let (ok, out) = run(Some(v));
        assert!(!ok, "with CI={v} the test fails:\n{out}");
        assert!(
            out.contains("CI is set but something missing is not available"),
            "{out}"
        );
    }
}
