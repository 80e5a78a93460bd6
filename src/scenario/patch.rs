//! Patching a scenario's tree by field path (`vehicles[0].markers.rotation_deg`): what a sweep
//! varies and what an `identify` fragment sets. It works on the parsed YAML/JSON tree, before
//! the scenario is validated, so a patched scenario is checked like a written one.

/// Sets the number at `path` (`a.b[2].c`) in a YAML/JSON tree; the containers must exist, a
/// missing last key of a mapping is added.
pub fn set_path(tree: &mut serde_json::Value, path: &str, x: f64) -> Result<(), String> {
    set_in(tree, path, serde_json::json!(x), false)
}

/// Sets `v` at `path` (`a.b[2].c`) in a YAML/JSON tree. Lists must exist and be long enough; a
/// missing last key of a mapping is added, and so are missing mappings on the way when
/// `create_mappings` holds (an `identify` fragment may set `mocap.camera_error` in a scenario
/// that has no `mocap`).
pub fn set_in(tree: &mut serde_json::Value, path: &str, v: serde_json::Value, create_mappings: bool) -> Result<(), String> {
    let mut cur = tree;
    let mut parts: Vec<(String, Option<usize>)> = Vec::new();
    for seg in path.split('.') {
        let (key, rest) = seg.split_once('[').map_or((seg, ""), |(k, r)| (k, r));
        if !key.is_empty() {
            parts.push((key.to_string(), None));
        }
        for idx in rest.split('[').filter(|s| !s.is_empty()) {
            let n = idx.trim_end_matches(']').parse::<usize>().map_err(|_| format!("`{path}`: `[{idx}` is not an index"))?;
            parts.push((String::new(), Some(n)));
        }
    }
    let last = parts.len().checked_sub(1).ok_or_else(|| "empty field path".to_string())?;
    let mut v = Some(v);
    for (k, (key, idx)) in parts.iter().enumerate() {
        let end = k == last;
        cur = match idx {
            Some(n) => {
                let len = cur.as_array().map(Vec::len).ok_or_else(|| format!("`{path}`: not a list before [{n}]"))?;
                if *n >= len {
                    return Err(format!("`{path}`: index {n} is outside the list (length {len})"));
                }
                &mut cur[*n]
            }
            None => {
                if create_mappings && cur.is_null() {
                    *cur = serde_json::json!({});
                }
                let obj = cur.as_object_mut().ok_or_else(|| format!("`{path}`: `{key}` is not inside a mapping"))?;
                if !obj.contains_key(key.as_str()) {
                    if !end && !create_mappings {
                        return Err(format!("`{path}`: `{key}` is not set in the scenario; write it out to vary inside it"));
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
        assert!(set_path(&mut t, "v[3].m", 1.0).unwrap_err().contains("outside the list"));
        assert!(set_path(&mut t, "x.y", 1.0).unwrap_err().contains("not set"));
    }
}
