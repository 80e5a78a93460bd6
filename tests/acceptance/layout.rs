//! The crate's layout: the library's top-level modules depend on each other in one
//! direction only, and so do the files inside each module folder; none of them reaches the
//! command line.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The part of a source file that is not test code: all of it up to its `#[cfg(test)]` module,
/// and nothing of a `tests.rs` (a folder's test module, declared `#[cfg(test)] mod tests;`).
fn non_test_code<'a>(f: &Path, text: &'a str) -> &'a str {
    if f.file_name().is_some_and(|n| n == "tests.rs") {
        return "";
    }
    text.split("#[cfg(test)]").next().unwrap()
}

/// Every `.rs` file under `dir`, at any depth.
fn rs_files(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut files = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            files.extend(rs_files(&p));
        } else if p.extension().is_some_and(|x| x == "rs") {
            files.push(p);
        }
    }
    files
}

/// Top-level module → the top-level modules its non-test code names as `crate::m` (comments
/// and `#[cfg(test)]` parts left out; `lib.rs` and the binary's `main.rs`, `cli.rs` are not
/// library modules).
fn module_graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let files = rs_files(src);
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in files {
        let rel = f.strip_prefix(src).unwrap();
        let top = rel.components().next().unwrap().as_os_str().to_string_lossy().trim_end_matches(".rs").to_string();
        if ["lib", "main", "cli"].contains(&top.as_str()) {
            continue;
        }
        let text = std::fs::read_to_string(&f).unwrap();
        let code = non_test_code(&f, &text);
        let deps = g.entry(top.clone()).or_default();
        for line in code.lines().filter(|l| !l.trim_start().starts_with("//")) {
            deps.extend(crate_edges(line).into_iter().filter(|n| *n != top));
        }
    }
    g
}

/// The top-level modules a line names through `crate::`: `crate::m::…`, each first name of a
/// group `crate::{a::x, b}`, and the umbrella error, `crate::Error` and `crate::Result`, which
/// live in `error`.
fn crate_edges(line: &str) -> Vec<String> {
    let ident = |s: &str| -> String { s.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect() };
    let mut names = Vec::new();
    for (i, _) in line.match_indices("crate::") {
        let rest = &line[i + 7..];
        match rest.strip_prefix('{') {
            Some(group) => {
                // first names at the group's top level
                let (mut depth, mut start) = (0, true);
                for (k, c) in group.char_indices() {
                    match c {
                        '{' => depth += 1,
                        '}' if depth == 0 => break,
                        '}' => depth -= 1,
                        ',' if depth == 0 => start = true,
                        c if start && !c.is_whitespace() => {
                            names.push(ident(&group[k..]));
                            start = false;
                        }
                        _ => {}
                    }
                }
            }
            None => names.push(ident(rest)),
        }
    }
    names
        .into_iter()
        .filter(|n| !n.is_empty())
        .map(|n| if n == "Error" || n == "Result" { "error".to_string() } else { n })
        .collect()
}

/// The edges a line gives, by hand: paths, a group, and the umbrella error's names.
#[test]
fn crate_paths_are_read_as_edges_to_modules() {
    assert_eq!(crate_edges("use crate::frames::{Body, Vec3};"), ["frames"]);
    assert_eq!(
        crate_edges("use crate::{log::LogError, scenario::{Scenario, Span}, Result};"),
        ["log", "scenario", "error"]
    );
    assert_eq!(crate_edges("fn f() -> crate::Result<()> { Err(crate::Error::Usage(x)) }"), ["error", "error"]);
}

/// A cycle of the graph, if there is one (depth-first search), as the path that closes it.
fn find_cycle(g: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        v: &str,
        g: &BTreeMap<String, BTreeSet<String>>,
        path: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        if let Some(k) = path.iter().position(|p| p == v) {
            let mut c = path[k..].to_vec();
            c.push(v.to_string());
            return Some(c);
        }
        if done.contains(v) {
            return None;
        }
        path.push(v.to_string());
        for w in g.get(v).into_iter().flatten() {
            if let Some(c) = visit(w, g, path, done) {
                return Some(c);
            }
        }
        path.pop();
        done.insert(v.to_string());
        None
    }
    let mut done = BTreeSet::new();
    g.keys().find_map(|v| visit(v, g, &mut Vec::new(), &mut done))
}

#[test]
fn the_library_modules_depend_one_way() {
    let g = module_graph(&super::root().join("src"));
    assert!(g.len() > 10 && g["engine"].contains("vehicle"), "the scan finds the modules: {g:?}");
    if let Some(c) = find_cycle(&g) {
        panic!("module cycle: {}", c.join(" → "));
    }
    for (m, deps) in &g {
        assert!(!deps.contains("cli"), "{m} imports the command line");
    }
}

/// Inside module folder `dir` (one with a `mod.rs`): each child (a file, or a sub-folder as one
/// node) → the children its non-test code names, as `super::x` from the folder's own files,
/// `super::super::x` from a sub-folder's, or the full `crate::…::x` path. `mod.rs` is the
/// folder's façade and not a node.
fn file_graph(src: &Path, dir: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let module: Vec<String> =
        dir.strip_prefix(src).unwrap().components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
    let full = format!("crate::{}::", module.join("::"));
    let children: BTreeSet<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir() || p.extension().is_some_and(|x| x == "rs"))
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .filter(|n| n != "mod")
        .collect();
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in rs_files(dir) {
        let rel: Vec<String> =
            f.strip_prefix(dir).unwrap().components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
        if rel == ["mod.rs"] {
            continue;
        }
        let node = rel[0].trim_end_matches(".rs").to_string();
        // `super::` of a file directly in the folder, or of a sub-folder's mod.rs, is the folder;
        // one level deeper it takes `super::super::`
        let depth = rel.len() - usize::from(rel.last().is_some_and(|l| l == "mod.rs"));
        let up = "super::".repeat(depth);
        let text = std::fs::read_to_string(&f).unwrap();
        let code = non_test_code(&f, &text);
        let deps = g.entry(node.clone()).or_default();
        for line in code.lines().filter(|l| !l.trim_start().starts_with("//")) {
            for prefix in [up.as_str(), full.as_str()] {
                for (i, _) in line.match_indices(prefix) {
                    // `super::super::x` also contains `super::x`: only the whole chain counts
                    if prefix == up && line[..i].ends_with("super::") {
                        continue;
                    }
                    let name: String =
                        line[i + prefix.len()..].chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
                    if children.contains(&name) && name != node {
                        deps.insert(name);
                    }
                }
            }
        }
    }
    g
}

/// Inside every module folder the files depend on each other in one direction only: a reader
/// can start from the leaves (identify's `input/`, `fit/stats.rs`) and never meet a file that
/// needs one not yet read. Between identify's stages too: `input/` needs no other stage, `fit/`
/// only `input/`, `checks/` and `output/` what comes before them.
#[test]
fn the_files_of_each_module_depend_one_way() {
    let src = super::root().join("src");
    let folders: Vec<_> = rs_files(&src)
        .into_iter()
        .filter(|f| f.ends_with("mod.rs"))
        .map(|f| f.parent().unwrap().to_path_buf())
        .collect();
    assert!(folders.iter().any(|f| f.ends_with("identify/fit/select")), "{folders:?}");
    // identify's stages are folders, and the scan sees the edges between them and inside them
    let identify = file_graph(&src, &src.join("identify"));
    let fit = file_graph(&src, &src.join("identify/fit"));
    assert!(
        identify["fit"].contains("input")
            && identify["checks"].contains("fit")
            && identify["output"].contains("fit")
            && !identify["input"].contains("fit"),
        "the scan finds the stages: {identify:?}"
    );
    assert!(fit["ground"].contains("stats") && fit["select"].contains("ground"), "the scan finds the files: {fit:?}");
    for dir in folders {
        let g = file_graph(&src, &dir);
        if let Some(c) = find_cycle(&g) {
            panic!("file cycle in {}: {}", dir.strip_prefix(&src).unwrap().display(), c.join(" → "));
        }
    }
}

/// The cycle finder on a graph with a known cycle (and without it).
#[test]
fn the_cycle_finder_finds_a_cycle() {
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let edge = |g: &mut BTreeMap<String, BTreeSet<String>>, a: &str, b: &str| {
        g.entry(a.into()).or_default().insert(b.into());
    };
    edge(&mut g, "a", "b");
    edge(&mut g, "b", "c");
    edge(&mut g, "a", "c");
    assert_eq!(find_cycle(&g), None);
    edge(&mut g, "c", "a");
    assert_eq!(find_cycle(&g), Some(vec!["a".into(), "b".into(), "c".into(), "a".into()]));
}

/// The length in lines of every function in `text` (from its `fn` line to its closing brace;
/// braces in comments, strings and char literals do not count), with its name.
fn function_lengths(text: &str) -> Vec<(String, usize)> {
    let lines: Vec<&str> = text.lines().collect();
    // a line's code: comments, strings and char literals blanked
    let code = |l: &str| -> String {
        let mut out = String::new();
        let mut chars = l.chars().peekable();
        while let Some(c) = chars.next() {
            match c {
                '/' if chars.peek() == Some(&'/') => break,
                '"' => {
                    while let Some(d) = chars.next() {
                        match d {
                            '\\' => {
                                chars.next();
                            }
                            '"' => break,
                            _ => {}
                        }
                    }
                }
                '\'' if matches!(chars.clone().nth(1), Some('\'')) => {
                    chars.nth(1);
                }
                _ => out.push(c),
            }
        }
        out
    };
    let mut out = Vec::new();
    for (i, l) in lines.iter().enumerate() {
        let t = l.trim_start();
        let Some(at) = t.find("fn ") else { continue };
        let head = &t[..at];
        if t.starts_with("//")
            || !(head.is_empty()
                || head
                    .split_whitespace()
                    .all(|w| w.starts_with("pub") || w == "const" || w == "async" || w == "unsafe"))
        {
            continue;
        }
        let name: String = t[at + 3..].chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
        let (mut depth, mut started) = (0i32, false);
        for (j, l2) in lines.iter().enumerate().skip(i) {
            let c = code(l2);
            for ch in c.chars() {
                match ch {
                    '{' => {
                        depth += 1;
                        started = true;
                    }
                    '}' => depth -= 1,
                    _ => {}
                }
            }
            if started && depth == 0 {
                out.push((name.clone(), j - i + 1));
                break;
            }
            if !started && c.trim_end().ends_with(';') {
                break; // a declaration without a body
            }
        }
    }
    out
}

/// No function of the library or the binary is longer than 100 lines (a long function
/// holds several jobs; ripgrep keeps under 1 % of its functions above 80 lines).
#[test]
fn no_function_is_longer_than_100_lines() {
    let files = rs_files(&super::root().join("src"));
    let (mut total, mut over_80, mut long) = (0, Vec::new(), Vec::new());
    for f in &files {
        for (name, n) in function_lengths(&std::fs::read_to_string(f).unwrap()) {
            total += 1;
            if n > 80 {
                over_80.push(format!("{}: {name} ({n} lines)", f.display()));
            }
            if n > 100 {
                long.push(format!("{}: {name} ({n} lines)", f.display()));
            }
        }
    }
    eprintln!("{} of {total} functions are over 80 lines:\n{}", over_80.len(), over_80.join("\n"));
    assert!(total > 500, "the scan finds the functions: {total}");
    assert!(long.is_empty(), "functions over 100 lines:\n{}", long.join("\n"));
    assert!(100 * over_80.len() <= total, "{} of {total} functions over 80 lines: more than 1 %", over_80.len());
}

/// The length scan by hand: a body with braces in a string, a char and a comment.
#[test]
fn function_lengths_skip_braces_in_strings_and_comments() {
    let text =
        "fn a() {\n    let s = \"{ {\"; // }\n    let c = '{';\n}\npub(crate) fn b(x: u8) -> u8 {\n    x\n}\nfn c();\n";
    assert_eq!(function_lengths(text), vec![("a".to_string(), 4), ("b".to_string(), 3)]);
}

/// `identify`'s stages are private: its `pub use` lines re-export items, and the only modules
/// they make public are the nine tools of their own; six views (`pub mod ground { pub use … }`)
/// hold nothing but re-exports of items. A stage module such as `select` or `ground` re-exported
/// whole would let callers reach past the façade again. A module is made public through the
/// folder that holds it (`pub use checks::{trials}`) or by `pub mod`.
#[test]
fn identify_makes_public_only_its_vocabulary_modules() {
    let src = super::root().join("src/identify");
    let text = std::fs::read_to_string(src.join("mod.rs")).unwrap();
    // the `pub use` statements, each joined onto one line
    let (mut public, mut views, mut statement) = (BTreeSet::new(), BTreeSet::new(), None::<String>);
    let mut in_view = false;
    for line in text.lines().map(str::trim) {
        if let Some(name) = line.strip_prefix("pub mod ") {
            match name.strip_suffix(" {") {
                Some(view) => {
                    views.insert(view.to_string());
                    in_view = true;
                }
                None => {
                    public.insert(name.trim_end_matches(';').to_string());
                }
            }
            continue;
        }
        if in_view && line == "}" {
            in_view = false;
            continue;
        }
        if line.starts_with("pub use ") {
            statement = Some(String::new());
        }
        let Some(s) = statement.as_mut() else {
            assert!(!in_view || line.starts_with("//!"), "a view holds re-exports only: {line}");
            continue;
        };
        s.push_str(line);
        if !line.ends_with(';') {
            continue;
        }
        let path = s["pub use ".len()..].trim_end_matches(';');
        // a view's `super::` is identify itself
        let path = if in_view { path.strip_prefix("super::").unwrap_or(path) } else { path };
        let (prefix, names) = path.rsplit_once("::").unwrap_or(("", path));
        let folder = src.join(prefix.replace("::", "/"));
        // a name is a module re-exported when its parent declares it public (a private module
        // of the same name as a re-exported function, `select::excitation`, is not)
        let parent = std::fs::read_to_string(folder.join("mod.rs")).unwrap_or_default();
        for name in names.trim_matches(|c| c == '{' || c == '}').split(',') {
            let name = name.split(" as ").next().unwrap_or("").trim();
            let declared = parent.lines().any(|l| {
                let l = l.trim();
                l == format!("pub mod {name};") || l == format!("pub(crate) mod {name};")
            });
            if !name.is_empty() && declared {
                public.insert(name.to_string());
            }
        }
        statement = None;
    }
    let set = |names: &[&str]| names.iter().map(|n| n.to_string()).collect::<BTreeSet<String>>();
    let tools = set(&["calibration", "handheld", "injected", "mapping", "px4", "ros2", "start", "trials", "ulog"]);
    assert_eq!(public, tools, "identify's public modules");
    let want = set(&["consistency", "ground", "quality", "report", "residual", "series"]);
    assert_eq!(views, want, "identify's views");
}

/// The module path of a file under `src` (`identify/fit/design.rs` → identify, fit, design; a
/// folder's `mod.rs` is the folder's module).
fn module_path(src: &Path, f: &Path) -> Vec<String> {
    let mut segs: Vec<String> =
        f.strip_prefix(src).unwrap().components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
    let last = segs.pop().unwrap();
    if last != "mod.rs" && last != "lib.rs" {
        segs.push(last.trim_end_matches(".rs").to_string());
    }
    segs
}

/// The paths in `code` that reach a module through another module's re-export: a segment that
/// is no module file at that place but the name of one deeper down (`crate::identify::design::`
/// for `identify/fit/design.rs`), from `crate::` or from a chain of `super::` (resolved against
/// `here`, the file's module path). Each such path is a second address of a room.
fn alias_paths(src: &Path, here: &[String], code: &str) -> Vec<String> {
    let is_module = |segs: &[String]| {
        let p = src.join(segs.join("/"));
        p.with_extension("rs").is_file() || p.join("mod.rs").is_file()
    };
    let deeper = |segs: &[String], name: &str| {
        let dir = src.join(segs.join("/"));
        dir.is_dir()
            && rs_files(&dir).iter().any(|f| {
                let rel = f.strip_prefix(&dir).unwrap();
                rel.components().count() > 1
                    && rel.components().any(|c| c.as_os_str().to_string_lossy().trim_end_matches(".rs") == name)
            })
    };
    let mut found = Vec::new();
    // an inline module (`pub mod ground { … }`, a view) is one level deeper than its file: its
    // `super::` is the file's module; it ends at the `}` indented as its `mod` line
    let mut inline: Vec<(String, String)> = Vec::new();
    for line in code.lines().filter(|l| !l.trim_start().starts_with("//")) {
        let indent = &line[..line.len() - line.trim_start().len()];
        if inline.last().is_some_and(|(_, at)| line == format!("{at}}}")) {
            inline.pop();
            continue;
        }
        if let Some(name) = line.trim_start().trim_start_matches("pub ").strip_prefix("mod ")
            && let Some(name) = name.strip_suffix(" {")
        {
            inline.push((name.to_string(), indent.to_string()));
            continue;
        }
        let here: Vec<String> = here.iter().cloned().chain(inline.iter().map(|(n, _)| n.clone())).collect();
        let mut starts: Vec<(usize, Vec<String>)> =
            line.match_indices("crate::").map(|(i, _)| (i + 7, Vec::new())).collect();
        for (i, _) in line.match_indices("super::").filter(|(i, _)| !line[..*i].ends_with("super::")) {
            let (mut at, mut base) = (i, here.clone());
            while line[at..].starts_with("super::") {
                base.pop();
                at += 7;
            }
            starts.push((at, base));
        }
        for (mut at, mut cur) in starts {
            loop {
                let seg: String = line[at..].chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
                let more = line[at + seg.len()..].starts_with("::");
                if seg.is_empty() || !more {
                    break;
                }
                let mut next = cur.clone();
                next.push(seg.clone());
                if is_module(&next) {
                    cur = next;
                    at += seg.len() + 2;
                    continue;
                }
                if deeper(&cur, &seg) {
                    found.push(format!("{}::{seg}", cur.join("::")));
                }
                break;
            }
        }
    }
    found
}

/// Each module has one address inside the crate: no code names a module through a façade's
/// re-export (`crate::identify::design::` for `identify::fit::design`), so a line tells where
/// it lives and the file graph above sees every edge. The scan finds such a path when one is
/// written (checked on text below), and finds none in the crate.
#[test]
fn the_crate_names_each_module_by_its_own_path() {
    let src = super::root().join("src");
    let here = |p: &str| p.split('/').map(str::to_owned).collect::<Vec<_>>();
    let planted = "use crate::identify::design::Effect;\nlet x = super::super::ground::UpAxis::Z;\nuse crate::identify::fit::design::Design;";
    assert_eq!(
        alias_paths(&src, &here("identify/output/note"), planted),
        ["identify::design", "identify::ground"],
        "the scan sees an alias from crate:: and from super::"
    );
    let view = "pub mod view {\n    pub use super::fit::ground::UpAxis;\n}\nuse super::fit::ground::UpAxis;";
    assert_eq!(
        alias_paths(&src, &here("identify"), view),
        ["::fit"],
        "a view's super:: is the file it sits in, and the view ends at its brace"
    );
    let mut aliases = Vec::new();
    for f in rs_files(&src) {
        let text = std::fs::read_to_string(&f).unwrap();
        let code = non_test_code(&f, &text);
        for a in alias_paths(&src, &module_path(&src, &f), code) {
            aliases.push(format!("{}: {a}", f.strip_prefix(&src).unwrap().display()));
        }
    }
    assert!(aliases.is_empty(), "modules named through a re-export:\n{}", aliases.join("\n"));
}
