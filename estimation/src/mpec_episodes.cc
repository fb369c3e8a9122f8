#include "mpec_episodes.h"

#include <cstdint>

#include "vinci/parallel/fork.h"
#include "vinci/parallel/wire.h"

namespace vinci::estimation::mpec_internal {
namespace {

using sim::MatrixXd;
using sim::VectorXd;

void PutVector(parallel::Writer* w, const VectorXd& v) {
  w->Put<std::int64_t>(v.size());
  for (Eigen::Index i = 0; i < v.size(); ++i) w->Put<double>(v[i]);
}
VectorXd GetVector(parallel::Reader* r) {
  VectorXd v(r->Get<std::int64_t>());
  for (Eigen::Index i = 0; i < v.size(); ++i) v[i] = r->Get<double>();
  return v;
}
void PutMatrix(parallel::Writer* w, const MatrixXd& m) {
  w->Put<std::int64_t>(m.rows());
  w->Put<std::int64_t>(m.cols());
  for (Eigen::Index i = 0; i < m.size(); ++i) w->Put<double>(m.data()[i]);
}
MatrixXd GetMatrix(parallel::Reader* r) {
  const auto rows = r->Get<std::int64_t>(), cols = r->Get<std::int64_t>();
  MatrixXd m(rows, cols);
  for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = r->Get<double>();
  return m;
}
void PutLines(parallel::Writer* w, const std::vector<std::string>& lines) {
  w->Put<std::int64_t>(static_cast<std::int64_t>(lines.size()));
  for (const std::string& l : lines) w->PutString(l);
}
std::vector<std::string> GetLines(parallel::Reader* r) {
  std::vector<std::string> lines(static_cast<std::size_t>(r->Get<std::int64_t>()));
  for (std::string& l : lines) l = r->GetString();
  return lines;
}

// An episode's state and run, bit for bit (its problem is not sent: a worker process has the
// caller's copy).
parallel::Buffer Encode(const EpisodeFit& fit, const EpisodeRun& run) {
  parallel::Buffer out;
  parallel::Writer w(&out);
  PutVector(&w, fit.x);
  w.Put<double>(fit.f);
  PutVector(&w, fit.gradient);
  PutMatrix(&w, fit.hessian);
  PutMatrix(&w, fit.covariance);
  PutMatrix(&w, fit.profile_covariance);
  w.Put<double>(fit.final_epsilon);
  PutVector(&w, fit.relaxed.lambda);
  PutVector(&w, fit.relaxed.z_l);
  PutVector(&w, fit.relaxed.z_u);
  w.Put<double>(fit.violation);
  w.Put<bool>(fit.converged);
  w.Put<bool>(fit.usable);
  w.PutString(fit.reason);
  w.Put<std::int32_t>(run.iterations);
  w.Put<std::int32_t>(run.stages);
  PutLines(&w, run.solver_lines);
  PutLines(&w, run.lines);
  w.Put<bool>(run.have_cov);
  return out;
}
void Decode(const parallel::Buffer& in, EpisodeFit* fit, EpisodeRun* run) {
  parallel::Reader r(in);
  fit->x = GetVector(&r);
  fit->f = r.Get<double>();
  fit->gradient = GetVector(&r);
  fit->hessian = GetMatrix(&r);
  fit->covariance = GetMatrix(&r);
  fit->profile_covariance = GetMatrix(&r);
  fit->final_epsilon = r.Get<double>();
  fit->relaxed.lambda = GetVector(&r);
  fit->relaxed.z_l = GetVector(&r);
  fit->relaxed.z_u = GetVector(&r);
  fit->violation = r.Get<double>();
  fit->converged = r.Get<bool>();
  fit->usable = r.Get<bool>();
  fit->reason = r.GetString();
  run->iterations = r.Get<std::int32_t>();
  run->stages = r.Get<std::int32_t>();
  run->solver_lines = GetLines(&r);
  run->lines = GetLines(&r);
  run->have_cov = r.Get<bool>();
}

}  // namespace

void ForEachEpisode(std::vector<EpisodeFit>* fits, int workers, const MpecSolverOptions& so,
                    const Progress& say, const EpisodeJob& job, std::vector<EpisodeRun>* runs) {
  const int ne = static_cast<int>(fits->size());
  runs->assign(static_cast<std::size_t>(ne), EpisodeRun());
  const bool forked = workers > 1;
  parallel::ForkDistributor processes(forked ? workers : 1);
  parallel::MapOptions mo;
  mo.chunk = 1;
  if (forked) {
    mo.on_chunk = [&](int e, int, const parallel::Buffer& out) {
      EpisodeRun& run = (*runs)[static_cast<std::size_t>(e)];
      Decode(out, &(*fits)[static_cast<std::size_t>(e)], &run);
      for (const std::string& l : run.solver_lines)
        if (so.progress) so.progress(l);
      for (const std::string& l : run.lines) say(l);
    };
  }
  processes.Map(
      parallel::Buffer(), ne,
      [&](const parallel::Buffer&, int e, int) {
        EpisodeFit& fit = (*fits)[static_cast<std::size_t>(e)];
        EpisodeRun& run = (*runs)[static_cast<std::size_t>(e)];
        if (!forked) {
          job(e, &fit, &run, so, say);
          return parallel::Buffer();
        }
        MpecSolverOptions local = so;
        local.progress = [&run](const std::string& l) { run.solver_lines.push_back(l); };
        job(e, &fit, &run, local, [&run](const std::string& l) { run.lines.push_back(l); });
        return Encode(fit, run);
      },
      mo);
}

}  // namespace vinci::estimation::mpec_internal
