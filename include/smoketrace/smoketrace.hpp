#pragma once
// smoketrace in one include: what a program needs to trace rays (trace(), trace_bundle() over a two-level
// scene) or to render frames (a scene file, the six-way textures, the frame renderer, PNG output). The
// library's layers, in the order they build on each other: core, geometry, accel, trace, smoke, render, truth, io
// (docs/design.md). Include a single header of a layer instead to keep a translation unit lean.

// Tracing: the two-level scene and DirectX Raytracing's TraceRay() rules on the CPU.
#include <smoketrace/accel/accel_scene.hpp>
#include <smoketrace/trace/trace.hpp>
#include <smoketrace/trace/trace_bundle.hpp>

// The thesis's optical-depth pipeline: particles, their stand-ins, the pass and the resolver (eq. 3.1), and the
// stand-ins' smooth density kernels.
#include <smoketrace/smoke/density_kernel.hpp>
#include <smoketrace/smoke/optical_depth_story.hpp>
#include <smoketrace/smoke/optical_path_lengths.hpp>
#include <smoketrace/smoke/particle_groups.hpp>
#include <smoketrace/smoke/smoke_scene.hpp>
#include <smoketrace/smoke/tube_generator.hpp>

// Frames: the scene description, six-way lighting, the view compositor and the frame loop.
#include <smoketrace/render/frame_renderer.hpp>
#include <smoketrace/render/kernel_fit.hpp>
#include <smoketrace/render/pixel_samples.hpp>
#include <smoketrace/render/pixel_story.hpp>
#include <smoketrace/render/sixway_baker.hpp>

// The ground truth: the smoke a frame depicts, rendered as a volume and converged (docs/ground-truth.md).
#include <smoketrace/truth/ground_truth.hpp>

// Files: scene files in, PNG, EXR, PFM and CSV out, never destroying what an output path names.
#include <smoketrace/io/depths_csv.hpp>
#include <smoketrace/io/exr_io.hpp>
#include <smoketrace/io/file_bytes.hpp>
#include <smoketrace/io/image_files.hpp>
#include <smoketrace/io/json_text_file.hpp>
#include <smoketrace/io/output_path.hpp>
#include <smoketrace/io/pfm_io.hpp>
#include <smoketrace/io/ply_points.hpp>
#include <smoketrace/io/png_io.hpp>
#include <smoketrace/io/scene_file.hpp>
#include <smoketrace/io/sixway_files.hpp>
#include <smoketrace/io/temporary_file.hpp>
