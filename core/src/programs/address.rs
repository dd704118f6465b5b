//! Where the gateway listens for programs: `tcp:HOST:PORT` or `unix:PATH`.

use std::fmt;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::str::FromStr;

/// The programs' address. Port 0 asks the system for a free port (tests);
/// the server reports the bound one.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Address {
    Tcp(SocketAddr),
    Unix(PathBuf),
}

/// The default: loopback only.
pub const DEFAULT: &str = "tcp:127.0.0.1:5790";

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("bad programs address `{text}`: {why} (expected `tcp:HOST:PORT` or `unix:PATH`)")]
pub struct AddressError {
    pub text: String,
    pub why: String,
}

impl FromStr for Address {
    type Err = AddressError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let err = |why: &str| AddressError {
            text: text.to_owned(),
            why: why.to_owned(),
        };
        if let Some(rest) = text.strip_prefix("tcp:") {
            rest.parse::<SocketAddr>()
                .map(Address::Tcp)
                .map_err(|e| err(&e.to_string()))
        } else if let Some(rest) = text.strip_prefix("unix:") {
            if rest.is_empty() {
                return Err(err("empty path"));
            }
            Ok(Address::Unix(PathBuf::from(rest)))
        } else {
            Err(err("unknown scheme"))
        }
    }
}

impl fmt::Display for Address {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Address::Tcp(a) => write!(f, "tcp:{a}"),
            Address::Unix(p) => write!(f, "unix:{}", p.display()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tcp_and_unix_addresses_round_trip() {
        for text in [
            "tcp:127.0.0.1:5790",
            "tcp:127.0.0.1:0",
            "unix:/tmp/petrel.sock",
        ] {
            let a: Address = text.parse().expect("parses");
            assert_eq!(a.to_string(), text);
        }
        assert_eq!(
            "tcp:[::1]:7".parse::<Address>().ok(),
            Some(Address::Tcp("[::1]:7".parse().expect("addr")))
        );
    }

    #[test]
    fn bad_addresses_are_errors_naming_the_text() {
        for text in [
            "127.0.0.1:5",
            "tcp:localhost",
            "tcp:1.2.3.4",
            "unix:",
            "udp:1.2.3.4:5",
        ] {
            let e = text.parse::<Address>().expect_err(text);
            assert!(e.to_string().contains(text), "{e}");
        }
    }
}
