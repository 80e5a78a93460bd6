//! Scenario errors: file, line, column, field path, what is allowed.

use std::fmt;
use std::path::PathBuf;

/// Where in a scenario file something is.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Span {
    /// Line, from 1.
    pub line: u32,
    /// Column, from 1.
    pub column: u32,
}

/// A scenario that cannot be run, with everything needed to fix it.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// The file cannot be read.
    #[error("cannot read {file}: {source}")]
    Io {
        /// The file.
        file: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The file is read but not a valid scenario.
    #[error("{}", render(file, span, path, message, snippet))]
    Invalid {
        /// The file.
        file: PathBuf,
        /// Where in it, when the parser knows.
        span: Option<Span>,
        /// The field path (`vehicles[0].markers.rotation_deg`).
        path: String,
        /// What is wrong and what is allowed.
        message: String,
        /// The lines around the span, marked.
        snippet: String,
    },
}

fn render(file: &std::path::Path, span: &Option<Span>, path: &str, message: &str, snippet: &str) -> String {
    let loc = match span {
        Some(s) => format!("{}:{}:{}", file.display(), s.line, s.column),
        None => file.display().to_string(),
    };
    let field = if path.is_empty() { String::new() } else { format!(" field `{path}`:") };
    let mut out = format!("{loc}:{field} {message}");
    if !snippet.is_empty() {
        out.push('\n');
        out.push_str(snippet);
    }
    out
}

impl ScenarioError {
    /// What is wrong, without the file, position and source lines: for a scenario patched in
    /// memory (a sweep's run, an effects fragment), whose positions are in no file.
    pub fn what(&self) -> String {
        match self {
            ScenarioError::Invalid { message, .. } => message.clone(),
            ScenarioError::Io { .. } => self.to_string(),
        }
    }

    /// The message without the source snippet (for one-line summaries and snapshots).
    pub fn headline(&self) -> String {
        match self {
            ScenarioError::Io { .. } => self.to_string(),
            ScenarioError::Invalid { file, span, path, message, .. } => render(file, span, path, message, ""),
        }
    }
}

/// The dotted path (`vehicles[1].markers.rotation_deg`) of the YAML node at `line`:`column` of a
/// block-style document, reconstructed from indentation. Flow collections report the key that
/// holds them.
pub(crate) fn yaml_path_at(src: &str, line: u32, column: u32) -> String {
    // stack of (indent, segment); list items push "[i]" segments at the indent of their dash
    let mut stack: Vec<(usize, String)> = Vec::new();
    let mut counters: Vec<(usize, usize)> = Vec::new(); // (indent of '-', items seen)
    for (i, raw) in src.lines().enumerate() {
        let lineno = i as u32 + 1;
        if lineno > line {
            break;
        }
        let text = raw.split(" #").next().unwrap_or("");
        if text.trim().is_empty() || text.trim_start().starts_with('#') {
            continue;
        }
        let mut indent = text.len() - text.trim_start().len();
        let mut rest = text.trim_start();
        while let Some(after) = rest.strip_prefix("- ").or_else(|| (rest == "-").then_some("")) {
            stack.retain(|(ind, seg)| *ind < indent || (*ind == indent && !seg.starts_with('[')));
            counters.retain(|(ind, _)| *ind <= indent);
            let idx = match counters.last_mut() {
                Some((ind, n)) if *ind == indent => {
                    *n += 1;
                    *n - 1
                }
                _ => {
                    counters.push((indent, 1));
                    0
                }
            };
            stack.push((indent, format!("[{idx}]")));
            indent += rest.len() - after.len();
            rest = after;
            if lineno == line && (column as usize) <= indent {
                return join(&stack);
            }
        }
        if lineno == line {
            // inside a flow mapping on this line: follow `{ key: ...` up to the column
            let start = text.len() - rest.len();
            let upto: String = text.chars().take((column as usize).saturating_sub(1)).skip(start).collect();
            let (flow, last_key) = flow_keys(&upto);
            if !flow.is_empty() || last_key.is_some() {
                let mut segs = flow;
                segs.extend(last_key);
                stack.retain(|(ind, _)| *ind < indent);
                let base = join(&stack);
                let tail = segs.join(".");
                return if base.is_empty() { tail } else { format!("{base}.{tail}") };
            }
        }
        // a flow collection (`{ a: 1 }`, `[1, 2]`) opens no block key
        if let Some((key, _)) = rest.split_once(':').filter(|_| !rest.starts_with(['{', '['])) {
            let key = key.trim().trim_matches('"').trim_matches('\'');
            stack.retain(|(ind, _)| *ind < indent);
            counters.retain(|(ind, _)| *ind < indent);
            stack.push((indent, key.to_string()));
        }
    }
    join(&stack)
}

/// The keys open in a flow mapping up to the end of `upto` (`{ a: { b: 1, c: ` gives `[a]` and
/// `c`): the enclosing keys, and the key whose value is being written, if any.
fn flow_keys(upto: &str) -> (Vec<String>, Option<String>) {
    let mut flow: Vec<String> = Vec::new();
    let mut token = String::new();
    let mut last_key: Option<String> = None;
    for ch in upto.chars() {
        match ch {
            '{' => {
                if let Some(k) = last_key.take() {
                    flow.push(k);
                }
                token.clear();
            }
            '}' => {
                flow.pop();
                token.clear();
            }
            ':' => last_key = Some(token.trim().to_string()),
            ',' => {
                token.clear();
                last_key = None;
            }
            c => token.push(c),
        }
    }
    (flow, last_key)
}

fn join(stack: &[(usize, String)]) -> String {
    let mut s = String::new();
    for (_, seg) in stack {
        if !seg.starts_with('[') && !s.is_empty() {
            s.push('.');
        }
        s.push_str(seg);
    }
    s
}

/// A YAML parser's error in `src` (read from `file`) as a [`ScenarioError::Invalid`]: the line,
/// column and field path of where it stopped, its message for the file's author with
/// `suggest` applied (a "did you mean"), and the lines around it under the file's name.
pub(crate) fn from_yaml(
    src: &str,
    file: &std::path::Path,
    e: &serde_saphyr::Error,
    suggest: impl Fn(&str) -> String,
) -> ScenarioError {
    let loc = e.location();
    let span = loc.filter(|l| l.line() > 0).map(|l| Span { line: l.line() as u32, column: l.column() as u32 });
    let path = span.as_ref().map(|s| yaml_path_at(src, s.line, s.column)).unwrap_or_default();
    let full = for_authors(&e.to_string());
    // serde-saphyr renders "error: line L column C: MESSAGE\n --> snippet"; keep both parts
    let (head, snippet) = full.split_once('\n').unwrap_or((&full, ""));
    let message = head.split_once(": ").map(|x| x.1).unwrap_or(head);
    let message = message
        .split_once(": ")
        .filter(|(a, _)| a.starts_with("column") || a.contains(" column "))
        .map_or(message, |x| x.1);
    // the snippet's header names the parser's `<input>`: name the file
    let snippet = snippet.replacen("--> <input>:", &format!("--> {}:", file.display()), 1);
    ScenarioError::Invalid { file: file.to_path_buf(), span, path, message: suggest(message), snippet }
}

/// Levenshtein distance, for "did you mean" suggestions.
pub(crate) fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            cur[j + 1] = (prev[j] + usize::from(ca != *cb)).min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

/// The candidate closest to `bad` by [`edit_distance`] within `max` edits (a typo, not another
/// name); of equals, the first in sorted order.
pub(crate) fn closest<'a>(bad: &str, candidates: impl IntoIterator<Item = &'a str>, max: usize) -> Option<&'a str> {
    candidates.into_iter().map(|c| (edit_distance(bad, c), c)).filter(|(d, _)| *d <= max).min().map(|x| x.1)
}

/// A YAML parser's message with the advice meant for programmers (serde-saphyr's API options:
/// `DuplicateKeyPolicy`, `from_str_multiple`, `ignore_binary_tag_for_string`) replaced by what
/// the file's author can do.
pub(crate) fn for_authors(message: &str) -> String {
    message
        .replace(", set DuplicateKeyPolicy in Options if acceptable", " (a key may appear once)")
        .replace(
            "multiple YAML documents detected; use from_str_multiple or from_str_multiple_with_options",
            "more than one YAML document (a second `---`): the file holds one",
        )
        .replace(
            " If you just use !!binary for documentation/annotation, set ignore_binary_tag_for_string in Options",
            "",
        )
}

/// Appends "did you mean `x`?" to serde's unknown-field/variant messages when a close name exists.
pub(crate) fn with_suggestion(message: &str) -> String {
    let Some(rest) = message.split("unknown field `").nth(1).or_else(|| message.split("unknown variant `").nth(1))
    else {
        return message.to_string();
    };
    let Some((bad, tail)) = rest.split_once('`') else { return message.to_string() };
    let candidates = tail.split("expected one of").nth(1).or_else(|| tail.split("expected").nth(1)).unwrap_or("");
    let names =
        candidates.split(|c: char| c == ',' || c.is_whitespace() || c == '`').filter(|c| !c.is_empty() && *c != "or");
    match closest(bad, names, 2.max(bad.len() / 3)) {
        Some(c) => format!("{message}; did you mean `{c}`?"),
        None => message.to_string(),
    }
}

impl fmt::Display for Span {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.line, self.column)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_of_a_nested_list_item_field() {
        let y = "name: x\nvehicles:\n  - name: a\n    model:\n      mass_kg: 1\n  - name: b\n    model:\n      mass_kg: -2\nplan: []\n";
        assert_eq!(yaml_path_at(y, 8, 16), "vehicles[1].model.mass_kg");
        assert_eq!(yaml_path_at(y, 5, 16), "vehicles[0].model.mass_kg");
        assert_eq!(yaml_path_at(y, 1, 7), "name");
    }

    #[test]
    fn path_inside_plan_items() {
        let y = "plan:\n  - takeoff: { altitude_m: 1 }\n  - hover:\n      duration_s: -1\n";
        assert_eq!(yaml_path_at(y, 4, 19), "plan[1].hover.duration_s");
        assert_eq!(yaml_path_at(y, 2, 3), "plan[0]");
        assert_eq!(yaml_path_at(y, 2, 30), "plan[0].takeoff.altitude_m");
        assert_eq!(yaml_path_at("seed: 1\nlink: { loss: { bernoulli: 1.5 } }\n", 2, 28), "link.loss.bernoulli");
        assert_eq!(yaml_path_at("plan:\n- hover: {}\n- land: {}\nnext: 1\n", 3, 1), "plan[1]");
    }

    /// Regression: an error pointing at the `{` of a list item written as a flow mapping
    /// reported the path `vehicles[1].{ name`.
    #[test]
    fn path_of_a_flow_mapping_list_item() {
        let y = "name: f\nvehicles:\n  - { name: v0, home_m: [0, 0] }\n  - { name: v1, home_m: [1, 0] }\n";
        assert_eq!(yaml_path_at(y, 4, 5), "vehicles[1]");
        assert_eq!(yaml_path_at(y, 4, 15), "vehicles[1].name");
    }

    /// The parser's advice to programmers is replaced, its own words kept.
    #[test]
    fn parser_messages_speak_to_the_files_author() {
        assert_eq!(
            for_authors("duplicate mapping key: seed, set DuplicateKeyPolicy in Options if acceptable"),
            "duplicate mapping key: seed (a key may appear once)"
        );
        assert_eq!(
            for_authors("multiple YAML documents detected; use from_str_multiple or from_str_multiple_with_options"),
            "more than one YAML document (a second `---`): the file holds one"
        );
        assert_eq!(for_authors("unknown field `x`"), "unknown field `x`");
    }

    #[test]
    fn suggestions_for_typos() {
        let m = "unknown field `latncy_ms`, expected one of `loss`, `latency_ms`";
        assert!(with_suggestion(m).ends_with("did you mean `latency_ms`?"));
        assert_eq!(with_suggestion("unknown field `zzz`, expected `loss`"), "unknown field `zzz`, expected `loss`");
    }
}
