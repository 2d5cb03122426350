//! The `twin` command line: `help` lists every command, `run` exits 1 when
//! an expectation the twin observes fails (as `sim run`), 0 when they hold,
//! 2 on a usage error.

use std::process::Command;

fn twin(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_twin")).args(args).output().expect("running twin");
    let text = String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    (out.status.code().unwrap_or(-1), text)
}

fn scenario(name: &str, expect: &str) -> String {
    let path = std::env::temp_dir().join(format!("twin-cli-{}-{name}.scn", std::process::id()));
    std::fs::write(&path, format!("description {name}\nmax 300ms\nat 100 send <HOME>\n{expect}\n")).unwrap();
    path.to_string_lossy().into_owned()
}

#[test]
fn help_lists_every_command() {
    let (code, text) = twin(&["--help"]);
    assert_eq!(code, 0, "{text}");
    for cmd in ["twin [boot", "twin home", "twin run FILE", "twin live [--pose", "--for", "--pace", "twin help"] {
        assert!(text.contains(cmd), "{cmd:?} missing from\n{text}");
    }
    let (code, text) = twin(&["bogus"]);
    assert_eq!(code, 2, "{text}");
    assert!(text.contains("unknown command bogus") && text.contains("usage:"), "{text}");
}

#[test]
fn run_exits_1_when_an_observable_expectation_fails() {
    let held = scenario("held", "expect line HOMING_STARTED\nexpect no-fault");
    let (code, text) = twin(&["run", &held]);
    assert_eq!(code, 0, "{text}");
    assert!(text.contains("2 expectation(s): 2 held, 0 failed"), "{text}");
    let failed = scenario("failed", "expect line NO_SUCH_LINE\nexpect no-fault");
    let (code, text) = twin(&["run", &failed]);
    assert_eq!(code, 1, "{text}");
    assert!(text.contains("[FAIL] a line contains \"NO_SUCH_LINE\""), "{text}");
    let (code, text) = twin(&["run"]);
    assert_eq!(code, 2, "{text}");
}
