// StewartTrinkle::LcpBlocks / LcpBlocksInto: the block partition of a step's LCP unknowns for
// the block solvers (per contact, or per contact patch of one body pair, with its support
// points and corner unknowns).
#include <algorithm>
#include <utility>
#include <vector>

#include "vinci/sim/formulations/stewart_trinkle.h"

namespace vinci::sim {

std::vector<std::vector<int>> StewartTrinkle::LcpBlocks(const Assembly& a, LcpBlocking blocking,
                                                        std::vector<std::vector<int>>* parts) {
  std::vector<std::vector<int>> blocks;
  LcpBlocksInto(a, blocking, &blocks, parts);
  return blocks;
}

namespace {

// LcpBlocksInto's per-thread buffers (allocation reuse only).
struct BlocksScratch {
  std::vector<int> corner_of;
  // Open patch block per unordered body pair (contacts) or body (support points): key, block,
  // members. Looked up linearly (a step has few body pairs).
  struct Open {
    std::pair<int, int> key;
    int block, members;
  };
  std::vector<Open> open;
};

}  // namespace

void StewartTrinkle::LcpBlocksInto(const Assembly& a, LcpBlocking blocking,
                                   std::vector<std::vector<int>>* blocks_out,
                                   std::vector<std::vector<int>>* parts) {
  thread_local BlocksScratch scratch;
  const int nc = static_cast<int>(a.contacts.size());
  const int nd = a.nd;
  const int nf = nc * nd;
  const SupportRows& sup = a.support;
  const int ns = sup.points(), nps = sup.columns(), s0 = nc + nf + nc;
  const int nk = static_cast<int>(a.corner_contact.size());
  const int o = nc + nf + nc + nps + ns;  // first corner unknown
  std::vector<int>& corner_of = scratch.corner_of;
  corner_of.assign(static_cast<std::size_t>(nc), -1);
  for (int k = 0; k < nk; ++k) corner_of[a.corner_contact[k]] = k;
  const bool patches = blocking == LcpBlocking::kContactPatch;

  // The vectors of *blocks_out (and *parts) are reused in order: `used` of them hold blocks.
  std::vector<std::vector<int>>& blocks = *blocks_out;
  std::size_t used = 0;
  std::vector<BlocksScratch::Open>& open = scratch.open;
  open.clear();
  // A full block is closed and the next member opens a new one.
  auto block_for = [&](std::pair<int, int> key) -> std::vector<int>& {
    if (patches) {
      BlocksScratch::Open* entry = nullptr;
      for (BlocksScratch::Open& e : open)
        if (e.key == key) {
          entry = &e;
          break;
        }
      if (entry != nullptr && entry->members < kMaxPatchContacts) {
        ++entry->members;
        return blocks[static_cast<std::size_t>(entry->block)];
      }
      if (entry != nullptr)
        *entry = {key, static_cast<int>(used), 1};  // the full block is replaced
      else
        open.push_back({key, static_cast<int>(used), 1});
    }
    if (used == blocks.size()) blocks.emplace_back();
    if (parts) {
      if (used == parts->size()) parts->emplace_back();
      (*parts)[used].clear();
    }
    blocks[used].clear();
    return blocks[used++];
  };
  // Records where the next member of `b` (the block just returned by block_for) begins.
  auto begin_part = [&](const std::vector<int>& b) {
    if (parts)
      (*parts)[static_cast<std::size_t>(&b - blocks.data())].push_back(static_cast<int>(b.size()));
  };
  for (int c = 0; c < nc; ++c) {
    const Contact& ct = a.contacts[c];
    std::vector<int>& b =
        block_for({std::min(ct.body_a, ct.body_b), std::max(ct.body_a, ct.body_b)});
    begin_part(b);
    b.push_back(c);
    for (int j = 0; j < nd; ++j) b.push_back(nc + c * nd + j);
    b.push_back(nc + nf + c);
    if (corner_of[c] >= 0) b.push_back(o + corner_of[c]);
  }
  // Support points: keyed (−1, body), apart from every contact pair.
  for (int k = 0; k < ns; ++k) {
    std::vector<int>& b = block_for({-1, sup.body[k]});
    begin_part(b);
    for (int j = 0; j < sup.count[k]; ++j) b.push_back(s0 + sup.first[k] + j);
    b.push_back(s0 + nps + k);
  }
  blocks.resize(used);
  if (parts) parts->resize(used);
}

}  // namespace vinci::sim
