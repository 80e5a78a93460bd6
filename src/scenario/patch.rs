//! Patching a scenario's tree by field path (`vehicles[0].markers.rotation_deg`): what a sweep
//! varies and what an `identify` fragment sets. It works on the parsed YAML/JSON tree, before
//! the scenario is validated, so a patched scenario is checked like a written one.

/// Why a field path cannot be set.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PatchError {
    /// The path is empty.
    #[error("empty field path")]
    Empty,
    /// A bracket does not hold an index.
    #[error("`{path}`: `[{index}` is not an index")]
    NotAnIndex {
        /// The whole path.
        path: String,
        /// What the bracket holds.
        index: String,
    },
    /// An index into something that is not a list.
    #[error("`{path}`: not a list before [{index}]")]
    NotAList {
        /// The whole path.
        path: String,
        /// The index.
        index: usize,
    },
    /// An index past the list's end.
    #[error("`{path}`: index {index} is outside the list (length {len})")]
    OutsideList {
        /// The whole path.
        path: String,
        /// The index.
        index: usize,
        /// The list's length.
        len: usize,
    },
    /// A key into something that is not a mapping.
    #[error("`{path}`: `{key}` is not inside a mapping")]
    NotAMapping {
        /// The whole path.
        path: String,
        /// The key.
        key: String,
    },
    /// A key the scenario does not write (its default cannot be patched inside).
    #[error("`{path}`: `{key}` is not set in the scenario; write it out to vary inside it")]
    NotSet {
        /// The whole path.
        path: String,
        /// The key.
        key: String,
    },
}

/// Sets the number at `path` (`a.b[2].c`) in a YAML/JSON tree; the containers must exist, a
/// missing last key of a mapping is added.
pub fn set_path(tree: &mut serde_json::Value, path: &str, x: f64) -> Result<(), PatchError> {
    set_in(tree, path, serde_json::json!(x), false)
}

/// Sets `v` at `path` (`a.b[2].c`) in a YAML/JSON tree. Lists must exist and be long enough; a
/// missing last key of a mapping is added, and so are missing mappings on the way when
/// `create_mappings` holds (an `identify` fragment may set `mocap.camera_error` in a scenario
/// that has no `mocap`).
pub fn set_in(
    tree: &mut serde_json::Value,
    path: &str,
    v: serde_json::Value,
    create_mappings: bool,
) -> Result<(), PatchError> {
    let mut cur = tree;
    let mut parts: Vec<(String, Option<usize>)> = Vec::new();
    for seg in path.split('.') {
        let (key, rest) = seg.split_once('[').map_or((seg, ""), |(k, r)| (k, r));
        if !key.is_empty() {
            parts.push((key.to_string(), None));
        }
        for idx in rest.split('[').filter(|s| !s.is_empty()) {
            let n = idx
                .trim_end_matches(']')
                .parse::<usize>()
                .map_err(|_| PatchError::NotAnIndex { path: path.into(), index: idx.into() })?;
            parts.push((String::new(), Some(n)));
        }
    }
    let last = parts.len().checked_sub(1).ok_or(PatchError::Empty)?;
    let mut v = Some(v);
    for (k, (key, idx)) in parts.iter().enumerate() {
        let end = k == last;
        cur = match idx {
            Some(n) => {
                let len = cur
                    .as_array()
                    .map(Vec::len)
                    .ok_or_else(|| PatchError::NotAList { path: path.into(), index: *n })?;
                if *n >= len {
                    return Err(PatchError::OutsideList { path: path.into(), index: *n, len });
                }
                &mut cur[*n]
            }
            None => {
                if create_mappings && cur.is_null() {
                    *cur = serde_json::json!({});
                }
                let obj = cur
                    .as_object_mut()
                    .ok_or_else(|| PatchError::NotAMapping { path: path.into(), key: key.clone() })?;
                if !obj.contains_key(key.as_str()) {
                    if !end && !create_mappings {
                        return Err(PatchError::NotSet { path: path.into(), key: key.clone() });
                    }
                    obj.insert(key.clone(), serde_json::Value::Null);
                }
                obj.get_mut(key.as_str()).expect("present")
            }
        };
        if end {
            *cur = v.take().expect("set once");
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_path_reaches_nested_fields() {
        let mut t = serde_json::json!({"a": {"b": [1.0, {"c": 2.0}]}, "v": [{"m": {"r": [0.0, 0.0, 0.0]}}]});
        set_path(&mut t, "a.b[1].c", 5.0).unwrap();
        set_path(&mut t, "v[0].m.r[2]", -3.0).unwrap();
        set_path(&mut t, "a.new", 1.5).unwrap();
        assert_eq!(t["a"]["b"][1]["c"], 5.0);
        assert_eq!(t["v"][0]["m"]["r"][2], -3.0);
        assert_eq!(t["a"]["new"], 1.5);
        assert_eq!(
            set_path(&mut t, "v[3].m", 1.0),
            Err(PatchError::OutsideList { path: "v[3].m".into(), index: 3, len: 1 })
        );
        assert_eq!(
            set_path(&mut t, "x.y", 1.0).unwrap_err().to_string(),
            "`x.y`: `x` is not set in the scenario; write it out to vary inside it"
        );
    }
}
