//! What a checkout holds besides the code: the product speaks of the project and its users, not
//! of how it was built, and the real data the tests read can be fetched and checked.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The text files a user reads or runs: the README, the guide, the code, its tests, scripts,
/// scenarios, mappings, benchmarks, fuzz targets, the mutation data's scripts and CI. Build and
/// data folders (`target`, `out`, `data`, fuzz's corpus) are not the product.
fn product_files() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else { return };
        for e in entries {
            let p = e.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().to_string();
            if p.is_dir() {
                if !["target", "corpus", "artifacts", "out", "__pycache__"].contains(&name.as_str()) {
                    walk(&p, out);
                }
            } else {
                out.push(p);
            }
        }
    }
    let root = super::root();
    let mut files = vec![root.join("README.md"), root.join("Cargo.toml")];
    for d in ["docs", "src", "tests", "scripts", "scenarios", "mappings", "rigs", "benches", "fuzz", "mutation", ".ci"]
    {
        walk(&root.join(d), &mut files);
    }
    files
}

/// Where `text` names a work session or a tracker issue by its number (the word, a space, a
/// digit), or a shard of the mutation census: the words of the project's history, which git keeps. An issue of
/// another project cited as "#21468" is not matched.
fn process_words(text: &str) -> Vec<String> {
    let lower = text.to_lowercase();
    let mut hits = Vec::new();
    for word in ["session", "sessions", "issue", "issues"] {
        for (i, _) in lower.match_indices(&format!("{word} ")) {
            let before = lower[..i].chars().next_back();
            let after = lower[i + word.len() + 1..].chars().next();
            if before.is_none_or(|c| !c.is_alphanumeric()) && after.is_some_and(|c| c.is_ascii_digit()) {
                hits.push(lower[i..].chars().take(30).collect());
            }
        }
    }
    for (i, _) in lower.match_indices(&["census", " shard"].concat()) {
        hits.push(lower[i..].chars().take(30).collect());
    }
    hits
}

/// No file of the product names a session, an issue or a shard of the mutation census by number.
#[test]
fn the_product_names_no_session_issue_or_census_shard() {
    let mut found = Vec::new();
    for f in product_files() {
        let Ok(text) = std::fs::read_to_string(&f) else { continue };
        for hit in process_words(&text) {
            found.push(format!("{}: {hit}", f.display()));
        }
    }
    assert!(found.is_empty(), "process words in the product:\n{}", found.join("\n"));
}

/// The matcher itself: numbered sessions and issues and shards of the census are found, words that
/// merely contain them, an issue cited by `#`, or a session without a number are not.
#[test]
fn process_words_are_found_and_nothing_else() {
    let s = ["Sess", "ion 4"].concat();
    assert_eq!(process_words(&format!("as {s} found")).len(), 1);
    assert_eq!(process_words(&["see ", "issu", "es 58 and 59"].concat()).len(), 1);
    assert_eq!(process_words(&["the cen", "sus shard"].concat()).len(), 1);
    assert!(
        process_words(&["PX4 issue #21468; a session of flights; reiss", "ue 3; the tiss", "ue 5"].concat()).is_empty()
    );
}

/// `scripts/fetch-data` from a local copy: every file of the manifest lands in the target, equal
/// to its source; a second run keeps them; a source file with one byte added fails its SHA-256
/// (exit 2, the file named) and leaves neither that file nor a temporary one in the target.
#[test]
fn fetch_data_copies_checks_and_refuses_a_corrupted_file() {
    let Some(data) = super::shared_data() else { return };
    if Command::new("python3").arg("--version").output().is_err() {
        assert!(std::env::var_os("CI").is_none(), "CI must have python3");
        eprintln!("skipped: no python3 here");
        return;
    }
    let root = super::root();
    let manifest = std::fs::read_to_string(root.join("scripts/data-manifest.tsv")).unwrap();
    let files: Vec<&str> = manifest
        .lines()
        .filter(|l| !l.starts_with('#') && !l.is_empty())
        .map(|l| l.split('\t').nth(1).unwrap())
        .collect();
    assert!(files.iter().filter(|f| f.starts_with("nanobench/dataset/") && f.ends_with(".csv")).count() >= 10);
    let fetch = |from: &Path, to: &Path| {
        Command::new("python3")
            .arg(root.join("scripts/fetch-data"))
            .arg("--from")
            .arg(from)
            .arg("--to")
            .arg(to)
            .output()
            .unwrap()
    };
    let target = super::Scratch::new("fetch-data");
    let out = fetch(&data, &target);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for f in &files {
        assert!(
            std::fs::read(target.join(f)).unwrap() == std::fs::read(data.join(f)).unwrap(),
            "{f} differs from its source"
        );
    }
    let again = fetch(&data, &target);
    assert!(again.status.success());
    assert_eq!(String::from_utf8_lossy(&again.stdout).lines().filter(|l| l.starts_with("ok ")).count(), files.len());

    // a corrupted source: one byte appended to one flight
    let bad = super::Scratch::new("fetch-data-bad-source");
    for f in &files {
        std::fs::create_dir_all(bad.join(f).parent().unwrap()).unwrap();
        std::fs::copy(data.join(f), bad.join(f)).unwrap();
    }
    let victim = files.iter().find(|f| f.ends_with(".csv")).unwrap();
    let mut bytes = std::fs::read(bad.join(victim)).unwrap();
    bytes.push(b'\n');
    std::fs::write(bad.join(victim), bytes).unwrap();
    std::fs::remove_file(target.join(victim)).unwrap();
    let out = fetch(&bad, &target);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(victim) && err.contains("SHA-256"), "{err}");
    assert!(!target.join(victim).exists(), "a file that failed its checksum was written");
    let dir = target.join(victim).parent().unwrap().to_path_buf();
    let leftovers: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with(".fetch-"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left behind");
}

/// The guide's chapter list is one list: the README's map and the guide's own table hold the
/// same rows (title, chapter, what it answers; the README's links one folder up), and mdBook's
/// `SUMMARY.md` names the same chapters in the same order. A chapter added to one place and not
/// the others, or a row reworded in one, fails here.
#[test]
fn the_chapter_list_is_the_same_in_the_readme_the_guide_and_the_book() {
    let root = super::root();
    let rows =
        |text: &str| -> Vec<String> { text.lines().filter(|l| l.starts_with("| [")).map(str::to_owned).collect() };
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let guide = std::fs::read_to_string(root.join("docs/README.md")).unwrap();
    let from_readme: Vec<String> = rows(&readme).iter().map(|r| r.replacen("](docs/", "](", 1)).collect();
    assert!(from_readme.len() >= 10, "{from_readme:?}");
    assert_eq!(from_readme, rows(&guide), "README.md's chapter table and docs/README.md's differ");
    let chapter = |row: &str| row.split("](").nth(1).and_then(|r| r.split(')').next()).unwrap_or("").to_owned();
    let summary = std::fs::read_to_string(root.join("docs/SUMMARY.md")).unwrap();
    let in_book: Vec<String> = summary.lines().filter(|l| l.trim_start().starts_with("- [")).map(&chapter).collect();
    assert_eq!(in_book, rows(&guide).iter().map(|r| chapter(r)).collect::<Vec<_>>(), "docs/SUMMARY.md's chapters");
}
