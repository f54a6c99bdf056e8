//! Head pose → eye views, projections, pose-trace formats.
