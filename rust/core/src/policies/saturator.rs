//! placeholder until the law lands
