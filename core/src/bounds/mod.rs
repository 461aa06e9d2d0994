//! Enclosures of the field along a ray: interval jets (`interval`), Taylor and max/min
//! inclusions (`inclusion`, 2023 §5.1, §6.1, app. A), bottom-up inclusions (`bottom_up`, 2023
//! §5.2, §6.2, app. B–C) and revised affine forms (`affine`, MATH.md §8).

pub mod affine;
pub mod bottom_up;
pub mod inclusion;
pub mod interval;
