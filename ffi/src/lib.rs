//! C ABI of kincal (filled by the C ABI issue).
#![cfg_attr(not(feature = "std"), no_std)]
