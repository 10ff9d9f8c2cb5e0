#pragma once
// `gat eval --motion M.bvh ...`: DenseGATs-style evaluation of displacement
// models and the LBS / DQS baselines against the dataset's reference deformer
// (Delta Mush on LBS), over every frame of retargeted test motions on the
// dataset's test characters; Markdown / JSON tables, error colour maps and
// loss curves. Called by cmd_eval when --motion is given.
namespace gat {
int eval_motion(int argc, char** argv);
}
