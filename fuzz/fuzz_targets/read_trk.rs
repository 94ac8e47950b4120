#![no_main]

use libfuzzer_sys::fuzz_target;
use strandfit_fuzz::{fuzz, Format, Target};

fuzz_target!(|data: &[u8]| fuzz(Target::Reader(Format::Trk), data));
