//! Help texts are for operators: every `--help` of `mesopush` (each subcommand, recursively)
//! and of `mesopush-fwsim` says what the command does, never which issue or round of the
//! project's history made it (`issue 6's fifth round`); and `mesopush-fwsim` describes itself,
//! not the host program.

use std::process::Command;

fn help(bin: &str, path: &[&str]) -> String {
    let out = Command::new(bin).args(path).arg("--help").output().expect("run the binary");
    assert!(out.status.success(), "{path:?} --help: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).expect("utf-8 help")
}

/// The subcommand names listed under `Commands:` (clap's layout), without `help`.
fn subcommands(text: &str) -> Vec<String> {
    let mut names = vec![];
    let mut inside = false;
    for line in text.lines() {
        if line.starts_with("Commands:") {
            inside = true;
            continue;
        }
        if inside {
            if !line.starts_with("  ") {
                break;
            }
            // A command's line is indented by two spaces; its wrapped description by more.
            let name = line.split_whitespace().next().unwrap_or("help");
            if !line.starts_with("   ") && name != "help" {
                names.push(name.to_string());
            }
        }
    }
    names
}

/// Whether `text` names an issue by number (`issue 6`, `Issue 17`, `issues 5`, `#22`).
fn names_an_issue(text: &str) -> Option<String> {
    let lower = text.to_lowercase();
    let words: Vec<&str> = lower.split_whitespace().collect();
    for w in words.windows(2) {
        let numbered = w[1].chars().next().is_some_and(|c| c.is_ascii_digit());
        if (w[0].trim_start_matches('(') == "issue" || w[0] == "issues") && numbered {
            return Some(format!("{} {}", w[0], w[1]));
        }
    }
    let hash = lower
        .match_indices('#')
        .find(|(i, _)| lower[i + 1..].chars().next().is_some_and(|c| c.is_ascii_digit()));
    hash.map(|(i, _)| lower[i..].chars().take(6).collect())
}

#[test]
fn the_issue_finder_finds_issues() {
    assert_eq!(names_an_issue("as issue 6's fifth round"), Some("issue 6's".into()));
    assert_eq!(names_an_issue("(Issue 17) cone").as_deref(), Some("(issue 17)"));
    assert!(names_an_issue("see #22 for").is_some());
    assert_eq!(names_an_issue("an issue with the line; 6 tries"), None);
}

#[test]
fn no_help_text_names_an_issue() {
    let bin = env!("CARGO_BIN_EXE_mesopush");
    let mut todo: Vec<Vec<String>> = vec![vec![]];
    let mut seen = 0;
    let mut offenders = vec![];
    while let Some(path) = todo.pop() {
        let args: Vec<&str> = path.iter().map(String::as_str).collect();
        let text = help(bin, &args);
        seen += 1;
        if let Some(hit) = names_an_issue(&text) {
            offenders.push(format!("mesopush {} --help: {hit}", path.join(" ")));
        }
        for sub in subcommands(&text) {
            let mut p = path.clone();
            p.push(sub);
            todo.push(p);
        }
    }
    // The top level, its subcommands and theirs (batch, rig, identify, ...): many more than 10.
    assert!(seen > 20, "only {seen} help texts found: is the Commands: parser broken?");
    let fwsim = help(env!("CARGO_BIN_EXE_mesopush-fwsim"), &[]);
    if let Some(hit) = names_an_issue(&fwsim) {
        offenders.push(format!("mesopush-fwsim --help: {hit}"));
    }
    assert!(offenders.is_empty(), "help texts naming issues:\n{}", offenders.join("\n"));
}

#[test]
fn fwsim_describes_itself_not_the_host() {
    let host = help(env!("CARGO_BIN_EXE_mesopush"), &[]);
    let fwsim = help(env!("CARGO_BIN_EXE_mesopush-fwsim"), &[]);
    let first = |t: &str| t.lines().next().unwrap_or("").to_string();
    assert_ne!(
        first(&host),
        first(&fwsim),
        "mesopush-fwsim's help opens with the host's:\n{fwsim}"
    );
    assert!(fwsim.contains("firmware simulator"), "{fwsim}");
    assert!(fwsim.contains("pseudo-terminal"), "{fwsim}");
    assert!(!fwsim.contains("design, execute and verify"), "the host's description:\n{fwsim}");
}
