//! optik-conformance: the conformance suite (issue 4). Not implemented yet.
