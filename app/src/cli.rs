//! Command-line definitions (clap). The contract is DESIGN.md's "Command line" section.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};
use skeletrace::backends::parse_backend_choice;
use skeletrace_core::backend::BackendChoice;
use skeletrace_core::methods::Protocol;
use skeletrace_core::model::generate::GeneratorKind;
use skeletrace_core::model::scene::SkeletonField;

/// Skeleton-based implicit surfaces: model, ray trace, compare root finders.
#[derive(Parser, Debug)]
#[command(name = "skeletrace", version, about)]
pub struct Cli {
    /// Scene to open in the editor (an embedded default scene when omitted).
    pub scene: Option<PathBuf>,
    /// Headless command.
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// Headless commands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Generate a scene (deterministic per seed).
    Generate(GenerateArgs),
    /// Validate a scene and print its counts, kernels and bounding box.
    Info(InfoArgs),
    /// Read an SWC morphology file (`id type x y z radius parent` per line) as a scene: one
    /// group per structure type, one skeleton per tree, the file's radii.
    Import(ImportArgs),
    /// Ray statistics of the root-finding methods against the reference tracer.
    Stats(StatsArgs),
    /// Render a scene to PNG: shaded, or step-count heat maps of one or several methods.
    Render(RenderArgs),
    /// Time full frames per method: median milliseconds over several frames.
    Bench(BenchArgs),
    /// Trace one pixel's camera ray with each method and print its steps: where each step
    /// stood, the field there, the bound it computed and how far that let it go.
    TraceRay(TraceRayArgs),
    /// Export the isosurface as a mesh: glTF (.glb, or .gltf with a .bin), STL, OBJ (with a
    /// .mtl) or PLY, by the output's extension.
    Export(ExportArgs),
}

/// Arguments of `info`.
#[derive(Args, Debug)]
pub struct InfoArgs {
    /// Scene file (.ron).
    pub scene: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `export`.
#[derive(Args, Debug)]
pub struct ExportArgs {
    /// Scene file (.ron).
    pub scene: PathBuf,
    /// Output file: .glb, .gltf, .stl (binary), .obj (with a .mtl beside it), .ply (binary) or
    /// .3mf.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Grid cells along the longest side of the field's support box (8 to 1024).
    #[arg(long, default_value_t = 128, value_parser = parse_resolution)]
    pub resolution: usize,
    /// Print the mesh's report (size, watertight, manifold, distance to the surface) as JSON.
    #[arg(long)]
    pub json: bool,
    /// Export past the memory limit (4 GB estimated; the estimate is printed first).
    #[arg(long)]
    pub allow_large: bool,
}

/// Arguments of `import`.
#[derive(Args, Debug)]
pub struct ImportArgs {
    /// SWC file.
    pub input: PathBuf,
    /// Output scene file (.ron).
    #[arg(short, long)]
    pub output: PathBuf,
}

/// Arguments of `bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Scene file (.ron).
    pub scene: PathBuf,
    /// Tracing backend: cpu, gpu, or auto (the GPU on a hardware adapter where it supports
    /// the method, the CPU otherwise).
    #[arg(long, value_parser = parse_backend_choice, default_value = "cpu")]
    pub backend: BackendChoice,
    /// Frame size, `WxH`.
    #[arg(long, default_value = "512x512")]
    pub size: String,
    /// `all` (every method the backend runs on this scene) or a comma-separated list.
    #[arg(long, default_value = "all")]
    pub methods: String,
    /// Timed frames per method, 1 to 10 000 (after untimed warm-up frames for at least 0.5 s).
    #[arg(long, default_value_t = 5, value_parser = parse_frames)]
    pub frames: usize,
    /// Settings profile: default, paper-2023 (forward inclusion), paper-2021 (SCALIS) or
    /// paper-2014 (numerical ray tracing notes).
    #[arg(long, value_parser = parse_protocol, default_value = "default")]
    pub protocol: Protocol,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Time the frames that follow edits, as the editor traces them while a vertex is dragged:
    /// every skeleton vertex and point blob in turn (at most 64, evenly spread) moved up by a
    /// twentieth of its radius, each edit compiled and its frame traced (`--frames` is unused).
    /// On the CPU by a backend that copies the tiles and rays the edit did not reach, on a GPU
    /// uploading the primitives the edit changed. Reports the median of those frames, the mean
    /// and slowest, and on the CPU the shares of tiles and pixels copied and how many edits
    /// copied nothing (traced in full).
    #[arg(long)]
    pub after_edits: bool,
    /// Time frames while one parameter changes, as a slider dragged in the editor: `--steps`
    /// values applied in turn to every group, primitive or operator that has the parameter,
    /// one frame traced after each; reports the pipelines compiled after the first frame, the
    /// median and slowest frame, and how far the frames are from the CPU tracer's.
    #[arg(long, value_enum, conflicts_with = "after_edits")]
    pub sweep: Option<SweepParam>,
    /// Values of a `--sweep`, 1 to 10 000.
    #[arg(long, default_value_t = 20, value_parser = parse_frames, requires = "sweep")]
    pub steps: usize,
}

/// A parameter `bench --sweep` changes.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SweepParam {
    /// Every group's kernel scale σ.
    KernelScale,
    /// Every skeleton vertex's and point blob's radius.
    Radius,
    /// The scene's isovalue.
    Isovalue,
    /// Every smooth union's and smooth intersection's width.
    SmoothWidth,
    /// Every Ricci blend's exponent.
    RicciExponent,
}

/// What a render shows.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum View {
    /// Blinn–Phong shading.
    Shaded,
    /// Step-count heat map with a colour bar.
    Steps,
}

/// How step counts map onto the heat maps' colour scale.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    /// `ln(1 + steps) / ln(1 + top)`: 5 and 2048 steps both readable.
    Log,
    /// `steps / top`.
    Linear,
}

/// Arguments of `render`.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (.ron).
    pub scene: PathBuf,
    /// Output PNG.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Method of a single render.
    #[arg(long, conflicts_with = "compare")]
    pub method: Option<String>,
    /// Comma-separated methods, one panel each (`all`: every method that applies).
    #[arg(long)]
    pub compare: Option<String>,
    /// Shaded or step counts (default: shaded for one method, steps for --compare).
    #[arg(long, value_enum)]
    pub view: Option<View>,
    /// Size of each panel, `WxH`.
    #[arg(long, default_value = "512x512")]
    pub size: String,
    /// Tracing backend: cpu, gpu, or auto (the GPU on a hardware adapter where it supports
    /// the method, the CPU otherwise).
    #[arg(long, value_parser = parse_backend_choice, default_value = "cpu")]
    pub backend: BackendChoice,
    /// Top of the step-count colour scale, 1 to 10⁹ (default: the largest count in the
    /// image).
    #[arg(long, value_parser = parse_steps_max)]
    pub steps_max: Option<u32>,
    /// Step-count colour scale.
    #[arg(long, value_enum, default_value = "log")]
    pub scale: Scale,
    /// Settings profile: default, paper-2023 (forward inclusion), paper-2021 (SCALIS) or
    /// paper-2014 (numerical ray tracing notes).
    #[arg(long, value_parser = parse_protocol, default_value = "default")]
    pub protocol: Protocol,
    /// Cast shadow rays in the shaded view.
    #[arg(long)]
    pub shadows: bool,
    /// Soft shadows estimated from the field (2014 notes §12.4; CPU and GPU).
    #[arg(long)]
    pub soft_shadows: bool,
    /// Ambient occlusion estimated from the field (2014 notes §12.4; CPU and GPU).
    #[arg(long)]
    pub ao: bool,
}

/// Arguments of `trace-ray`.
#[derive(Args, Debug)]
pub struct TraceRayArgs {
    /// Scene file (.ron).
    pub scene: PathBuf,
    /// Pixel `X,Y` (from the top left) of a frame of `--size`, as `render` numbers them.
    #[arg(long)]
    pub pixel: String,
    /// Frame size, `WxH`.
    #[arg(long, default_value = "512x512")]
    pub size: String,
    /// `all` (every method that applies) or a comma-separated list.
    #[arg(long, default_value = "all")]
    pub methods: String,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `stats`.
#[derive(Args, Debug)]
pub struct StatsArgs {
    /// Scene file (.ron).
    pub scene: PathBuf,
    /// `all` or a comma-separated list of method names.
    #[arg(long, default_value = "all")]
    pub methods: String,
    /// Number of rays (a sixth per axis direction): 6 to 10⁷ on the CPU, to 10⁸ on the GPU.
    #[arg(long, default_value_t = 6000)]
    pub rays: usize,
    /// Seed of the ray origins.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Settings profile: default, paper-2023 (forward inclusion), paper-2021 (SCALIS) or
    /// paper-2014 (numerical ray tracing notes).
    #[arg(long, value_parser = parse_protocol, default_value = "default")]
    pub protocol: Protocol,
    /// Trace every crossing (transparent rays, forward-inclusion 2023 Tables 3–4) instead of
    /// the first.
    #[arg(long)]
    pub transparent: bool,
    /// Print the DESIGN.md JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Tracing backend: cpu, gpu (millions of rays in batches; opaque only), or auto (the GPU
    /// on a hardware adapter).
    #[arg(long, value_parser = parse_backend_choice, default_value = "cpu")]
    pub backend: BackendChoice,
    /// On the GPU: how many of the rays (the first ones) are compared with the reference
    /// tracer, which runs on the CPU; missed and spurious count among them. 1 to 10⁷.
    #[arg(long, default_value_t = 20_000, value_parser = parse_compared)]
    pub compared: usize,
}

/// Arguments of `generate`.
#[derive(Args, Debug)]
pub struct GenerateArgs {
    /// What to generate.
    pub kind: Kind,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Size: tree depth, segments (random-skeleton), Voronoi cells (foam), lattice cells per
    /// side (truss), blobs or atoms; 1 to 10⁹ (sizes that would build more than a million
    /// primitives are refused without --allow-large).
    #[arg(long, value_parser = parse_generate_size)]
    pub size: Option<usize>,
    /// Number of blob groups blended by max (blobs), 1 to 10⁶.
    #[arg(long, value_parser = parse_groups)]
    pub groups: Option<usize>,
    /// Radii along skeletons (random-skeleton, foam).
    #[arg(long, value_enum, default_value_t = Radii::Constant)]
    pub radii: Radii,
    /// Field type of skeleton segments.
    #[arg(long, value_enum, default_value_t = Field::Scalis)]
    pub field: Field,
    /// Build scenes over the limit of 1 000 000 primitives (about 400 MB).
    #[arg(long)]
    pub allow_large: bool,
    /// Output scene file.
    #[arg(short, long)]
    pub output: PathBuf,
}

/// Generator kinds.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum Kind {
    /// Branching skeleton, radii shrinking towards the tips.
    Tree,
    /// Random walk with branches.
    RandomSkeleton,
    /// Edges of a Voronoi diagram.
    Foam,
    /// Lattice truss.
    Truss,
    /// Random point blobs, max of sums.
    Blobs,
    /// Gaussian atoms.
    Molecule,
}

impl From<Kind> for GeneratorKind {
    fn from(k: Kind) -> Self {
        match k {
            Kind::Tree => Self::Tree,
            Kind::RandomSkeleton => Self::RandomSkeleton,
            Kind::Foam => Self::Foam,
            Kind::Truss => Self::Truss,
            Kind::Blobs => Self::Blobs,
            Kind::Molecule => Self::Molecule,
        }
    }
}

/// Radius modes.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum Radii {
    /// One radius everywhere.
    Constant,
    /// Random radii per vertex.
    Varying,
}

/// Skeleton field types.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum Field {
    /// SCALIS integral (scalis eq. 8).
    Scalis,
    /// Homothetic distance (scalis eq. 7).
    Distance,
}

impl From<Field> for SkeletonField {
    fn from(f: Field) -> Self {
        match f {
            Field::Scalis => Self::Scalis,
            Field::Distance => Self::Distance,
        }
    }
}

fn parse_protocol(name: &str) -> Result<Protocol, String> {
    name.parse()
}

fn parse_resolution(text: &str) -> Result<usize, String> {
    let range = skeletrace::export::RESOLUTIONS;
    text.parse()
        .ok()
        .filter(|r| range.contains(r))
        .ok_or_else(|| {
            format!(
                "expected a number of grid cells from {} to {}",
                range.start(),
                range.end()
            )
        })
}

/// A whole number in `range`, or a message stating the range.
fn in_range<T>(text: &str, range: std::ops::RangeInclusive<T>) -> Result<T, String>
where
    T: std::str::FromStr + PartialOrd + std::fmt::Display,
{
    text.trim()
        .parse()
        .ok()
        .filter(|n| range.contains(n))
        .ok_or_else(|| {
            format!(
                "expected a whole number from {} to {}",
                range.start(),
                range.end()
            )
        })
}

fn parse_frames(text: &str) -> Result<usize, String> {
    in_range(text, 1..=10_000)
}

fn parse_steps_max(text: &str) -> Result<u32, String> {
    in_range(text, 1..=1_000_000_000)
}

fn parse_compared(text: &str) -> Result<usize, String> {
    in_range(text, 1..=10_000_000)
}

fn parse_generate_size(text: &str) -> Result<usize, String> {
    in_range(text, 1..=1_000_000_000)
}

fn parse_groups(text: &str) -> Result<usize, String> {
    in_range(text, 1..=1_000_000)
}
