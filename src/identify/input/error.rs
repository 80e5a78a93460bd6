//! Why an input of `identify` cannot be used: a mapping, a log of another tool, a ROS 2 bag, a
//! flyarena log with its scenario, a scenario with an effects fragment. Every variant names the
//! file, and the line and column where the defect has one; nothing here is a number made from
//! bad data (the data-quality gate's own verdict is [`IdentifyError`](crate::identify::IdentifyError)).
//! A scenario that does not parse and a flyarena log that does not read are inputs of `identify`
//! too: their own errors arrive here whole ([`InputError::Scenario`], [`InputError::FlyarenaLog`]), and
//! the whole workflow's error is [`crate::identify::Error`].

use std::fmt::Display;

/// An `identify` input that cannot be used, with where and why.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// A scenario (the input, or the one a flyarena log was flown with) that cannot be run.
    #[error(transparent)]
    Scenario(#[from] crate::scenario::ScenarioError),
    /// A flyarena log that does not read.
    #[error(transparent)]
    FlyarenaLog(#[from] crate::log::LogError),
    /// A file that cannot be read.
    #[error("{file}: {source}")]
    Io {
        /// The file.
        file: String,
        /// Why.
        source: std::io::Error,
    },
    /// A mapping or an effects fragment that is not valid: the parser's message carries the
    /// line and column when it knows them.
    #[error("{file}: {message}")]
    Invalid {
        /// The mapping or fragment.
        file: String,
        /// What is wrong, and where.
        message: String,
    },
    /// A mapping that is not YAML of its form (an unknown key, a wrong type): the file, line,
    /// column and key, what is allowed, and the lines around it.
    #[error("{0}")]
    Yaml(crate::scenario::ScenarioError),
    /// A defect of a log's row: `line` counts from 1 (the header), `column` is the header's
    /// name of the cell when the defect is in one.
    #[error("{file}:{line}: {}{message}", column.as_ref().map_or(String::new(), |c| format!("column `{c}`: ")))]
    Row {
        /// The log.
        file: String,
        /// The line (1 is the header).
        line: usize,
        /// The header's name of the cell, when the defect is in one.
        column: Option<String>,
        /// What is wrong.
        message: String,
    },
    /// A defect of a log as a whole: empty, not text, fewer than two rows, a column the
    /// mapping names and the log lacks, a format the mapping cannot read.
    #[error("{file}: {message}")]
    Log {
        /// The log.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// A ROS 2 bag's message that does not decode (its topic, sequence number and schema).
    #[error("{file}: topic `{topic}`, message {sequence} ({schema}): {reason}")]
    Message {
        /// The bag.
        file: String,
        /// The message's topic.
        topic: String,
        /// Its sequence number.
        sequence: u32,
        /// Its schema's name.
        schema: String,
        /// What is wrong.
        reason: String,
    },
    /// Every flight of a cross-validation failed the data-quality gate (each one's reason).
    #[error("{}", .0.join("\n"))]
    NoFlightPasses(Vec<String>),
}

impl InputError {
    pub(crate) fn io(file: impl Display, source: std::io::Error) -> Self {
        InputError::Io { file: file.to_string(), source }
    }
    pub(crate) fn invalid(file: impl Display, message: impl Display) -> Self {
        InputError::Invalid {
            file: file.to_string(),
            message: crate::scenario::error::for_authors(&message.to_string()),
        }
    }
    pub(crate) fn log(file: impl Display, message: impl Display) -> Self {
        InputError::Log { file: file.to_string(), message: message.to_string() }
    }
    pub(crate) fn row(file: impl Display, line: usize, message: impl Display) -> Self {
        InputError::Row { file: file.to_string(), line, column: None, message: message.to_string() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rendered messages are the ones users and the pinned tests read: `file:line: column
    /// `c`: what`, and without a column `file:line: what`.
    #[test]
    fn a_row_error_names_file_line_and_column() {
        let e = InputError::Row {
            file: "log.csv".into(),
            line: 7,
            column: Some("gx".into()),
            message: "`x` is not a finite number".into(),
        };
        assert_eq!(e.to_string(), "log.csv:7: column `gx`: `x` is not a finite number");
        assert_eq!(InputError::row("log.csv", 3, "time goes backwards").to_string(), "log.csv:3: time goes backwards");
        let m = InputError::Message {
            file: "b.mcap".into(),
            topic: "/imu".into(),
            sequence: 4,
            schema: "sensor_msgs/msg/Imu".into(),
            reason: "cut short".into(),
        };
        assert_eq!(m.to_string(), "b.mcap: topic `/imu`, message 4 (sensor_msgs/msg/Imu): cut short");
    }
}
