//! Reading: every source `identify` takes becomes one [`Series`](series::Series) in flyarena's
//! frames (mocap world NED, body FRD, SI units): flyarena's own logs with their scenario,
//! another tool's CSV through a column mapping, ROS 2 bags and PX4 logs joined onto the IMU's
//! clock, and two streams on clocks of their own (an ASL/EuRoC folder, an IMU CSV beside a TUM
//! pose file) joined once the global start has found how their clocks stand. What cannot be read is an [`InputError`](error::InputError) naming the file and where.

pub mod error;
pub mod flyarena_log;
pub mod joined;
pub mod mapping;
pub mod read_note;
pub mod ros2;
pub mod series;
pub mod streams;
pub mod ulog;
