//! The Scientifica "LinLab" command line, parsed: one `\r`-terminated ASCII line in, one
//! [`Command`] out. Case-insensitive; arguments are separated by spaces.
//!
//! Only the commands a point-to-point driver uses are recognised (controller-protocol
//! notes, section 3.2: acq4 `Scientifica/scientifica.py`, Micro-Manager `Scientifica.cpp`,
//! ScanImage `LinearStageController.m`); anything else is [`Command::Unknown`] and the
//! emulator answers it with an error.

/// An axis of the stage.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// X.
    X,
    /// Y.
    Y,
    /// Z.
    Z,
}

impl Axis {
    /// Index 0..3.
    pub fn index(self) -> usize {
        self as usize
    }

    fn parse(s: &str) -> Option<Self> {
        match s {
            "X" => Some(Self::X),
            "Y" => Some(Self::Y),
            "Z" => Some(Self::Z),
            _ => None,
        }
    }
}

/// A motion parameter read with `NAME` and written with `NAME value`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Param {
    /// `TOP`: top speed.
    Top,
    /// `FIRST`: start speed.
    First,
    /// `ACC`: acceleration.
    Acc,
}

/// The per-axis scale commands: `UUX`/`UUY`/`UUZ` (v2 cards), `USTEP X` … (v3 cards).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScaleCmd {
    /// `UUX` family (v2 user units).
    Uu,
    /// `USTEP X` family (v3).
    Ustep,
}

/// One parsed command line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Command {
    /// `SCIENTIFICA`.
    Identify,
    /// `VER`.
    Version,
    /// `DESC`.
    Description,
    /// `TYPE`.
    Type,
    /// `POS` (both cards) or `P` (`short` = true; v3 only).
    Position {
        /// Sent as `P`.
        short: bool,
    },
    /// `PX` / `PY` / `PZ`.
    AxisPosition(Axis),
    /// `PX n`: set the position counter of one axis.
    SetAxisPosition(Axis, i64),
    /// `ZERO`: all counters to 0.
    Zero,
    /// `ABS x y z`, `ABS x y` or `ABSZ z`: absolute move (`None` = axis unchanged).
    Abs([Option<i64>; 3]),
    /// `REL dx dy dz` or `REL dx dy`: relative move.
    Rel([i64; 3]),
    /// `S`: busy status.
    Status,
    /// `STOP`.
    Stop,
    /// `LIMITS`.
    Limits,
    /// Read a parameter.
    Get(Param),
    /// Write a parameter.
    Set(Param, f64),
    /// Read an axis scale.
    GetScale(ScaleCmd, Axis),
    /// Write an axis scale.
    SetScale(ScaleCmd, Axis, f64),
    /// `BAUD 96` / `BAUD 38`: the new rate, bits/s (no reply).
    Baud(u32),
    /// A known command with missing or malformed arguments.
    BadArgument,
    /// Not a known command.
    Unknown,
}

fn ints<const K: usize>(args: &[&str]) -> Option<[i64; K]> {
    if args.len() != K {
        return None;
    }
    let mut out = [0; K];
    for (o, a) in out.iter_mut().zip(args) {
        *o = a.parse().ok()?;
    }
    Some(out)
}

fn number(args: &[&str]) -> Option<f64> {
    match args {
        [a] => a.parse::<f64>().ok().filter(|v| v.is_finite()),
        _ => None,
    }
}

/// Parses one line (without its `\r`).
pub fn parse(line: &str) -> Command {
    let upper = line.to_ascii_uppercase();
    let words: Vec<&str> = upper.split_whitespace().collect();
    let Some((&head, args)) = words.split_first() else {
        return Command::Unknown;
    };
    let bad = Command::BadArgument;
    let param = |p: Param| match args {
        [] => Command::Get(p),
        _ => number(args).map_or(bad, |v| Command::Set(p, v)),
    };
    match head {
        "SCIENTIFICA" => Command::Identify,
        "VER" => Command::Version,
        "DESC" => Command::Description,
        "TYPE" => Command::Type,
        "POS" => Command::Position { short: false },
        "P" => Command::Position { short: true },
        "ZERO" => Command::Zero,
        "S" => Command::Status,
        "STOP" => Command::Stop,
        "LIMITS" => Command::Limits,
        "TOP" => param(Param::Top),
        "FIRST" => param(Param::First),
        "ACC" => param(Param::Acc),
        "PX" | "PY" | "PZ" => axis_position(&head[1..], args),
        "UUX" | "UUY" | "UUZ" => scale(ScaleCmd::Uu, &head[2..], args),
        "USTEP" => match args.split_first() {
            Some((axis, rest)) => scale(ScaleCmd::Ustep, axis, rest),
            None => bad,
        },
        "ABS" => match args.len() {
            3 => ints::<3>(args).map_or(bad, |v| Command::Abs(v.map(Some))),
            2 => ints::<2>(args).map_or(bad, |[x, y]| Command::Abs([Some(x), Some(y), None])),
            _ => bad,
        },
        "ABSZ" => ints::<1>(args).map_or(bad, |[z]| Command::Abs([None, None, Some(z)])),
        "REL" => match args.len() {
            3 => ints::<3>(args).map_or(bad, Command::Rel),
            2 => ints::<2>(args).map_or(bad, |[x, y]| Command::Rel([x, y, 0])),
            _ => bad,
        },
        "BAUD" => match args {
            ["96"] => Command::Baud(9600),
            ["38"] => Command::Baud(38_400),
            _ => bad,
        },
        _ => Command::Unknown,
    }
}

fn axis_position(axis: &str, args: &[&str]) -> Command {
    let Some(a) = Axis::parse(axis) else { return Command::Unknown };
    match args {
        [] => Command::AxisPosition(a),
        _ => ints::<1>(args).map_or(Command::BadArgument, |[v]| Command::SetAxisPosition(a, v)),
    }
}

fn scale(cmd: ScaleCmd, axis: &str, args: &[&str]) -> Command {
    let Some(a) = Axis::parse(axis) else { return Command::BadArgument };
    match args {
        [] => Command::GetScale(cmd, a),
        _ => number(args).map_or(Command::BadArgument, |v| Command::SetScale(cmd, a, v)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_case_insensitively_with_arguments() {
        assert_eq!(parse("abs 10 -20 30"), Command::Abs([Some(10), Some(-20), Some(30)]));
        assert_eq!(parse("ABS 1 2"), Command::Abs([Some(1), Some(2), None]));
        assert_eq!(parse("Top 30000.000000"), Command::Set(Param::Top, 30000.0));
        assert_eq!(parse("ustep x"), Command::GetScale(ScaleCmd::Ustep, Axis::X));
        assert_eq!(parse("UUY -6.4"), Command::SetScale(ScaleCmd::Uu, Axis::Y, -6.4));
        assert_eq!(parse("ABS 1 x 3"), Command::BadArgument);
        assert_eq!(parse("INTERRUPT"), Command::Unknown);
        assert_eq!(parse("px 0"), Command::SetAxisPosition(Axis::X, 0));
    }
}
