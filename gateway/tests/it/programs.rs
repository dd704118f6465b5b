//! Software programs end to end: the program server with real child
//! processes (a scripted Python fixture and the skeletons `petrel stubs`
//! writes), over 127.0.0.1 and Unix sockets. Every wait is bounded.

use gateway::programs;

use crate::scratch;

mod support;

mod server;

mod stubs;
