//! Lines for the user, on stderr and stdout, that cannot take the program
//! down. `eprintln!` and `println!` panic when their stream is a pipe whose
//! reader has gone (`glint render … 2>&1 | head -1`, a client that stopped
//! reading the daemon's status lines): the render would then be lost
//! unwritten. A line nobody can read is dropped instead.

/// A line on stderr (messages, warnings, the summary).
#[macro_export]
macro_rules! stderr_line {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr().lock(), $($arg)*);
    }};
}

/// A line on stdout (`inspect`'s report, the daemon's status lines).
#[macro_export]
macro_rules! stdout_line {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout().lock(), $($arg)*);
    }};
}
