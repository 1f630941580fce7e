//! placeholder until the EDMD engine lands
