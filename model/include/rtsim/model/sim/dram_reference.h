#pragma once
// A DRAM model nobody here wrote, behind the calls the cycle level's DRAM target
// (CycleDram) and `rtsim dram-replay` make of ours: `dram.model = dramsim3` serves
// the requests with DRAMsim3 (umd-memsys/DRAMsim3), linked from a copy the user
// built, when rtsim was configured with -DRTSIM_DRAMSIM3=DIR (off by default; the
// normal build does not need it). docs/dram.md "Checked against" says how.
//
// The reference is configured from our DramConfig (dramsim3_ini): the same part's
// timings, organisation, address mapping, page policy and queue sizes, so that a
// difference in the results is a difference of the controllers, not of the inputs.
#include <rtsim/model/sim/dram.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace rtsim::sim {

class DramReference {
 public:
  virtual ~DramReference() = default;
  virtual bool can_accept(uint64_t address, bool write) const = 0;
  // now_ps: the enqueue time, at or after the previous advance.
  virtual void enqueue(const DramRequest& request, uint64_t now_ps) = 0;
  virtual void advance(uint64_t now_ps, std::vector<DramCompletion>& done) = 0;
  // The next time advance has work (UINT64_MAX when nothing is outstanding).
  virtual uint64_t next_decision_ps() const = 0;
  // End of the run: request counts and latencies were fed into `counts` as requests
  // completed; this adds the reference's command counts (row hits, activates, ...).
  virtual void finish(uint64_t end_ps, DramModel& counts) = 0;
};

// Whether this rtsim was built with a DRAMsim3 (-DRTSIM_DRAMSIM3=DIR).
bool dramsim3_linked();

// DRAMsim3's configuration (.ini text) for our DRAM configuration; InputError
// naming dram.model when DRAMsim3 cannot express it (a part it has no protocol
// for, a mapping without a bankgroup field, transactions other than one line).
std::string dramsim3_ini(const DramConfig& config, uint32_t access_bytes);

// A DRAMsim3 instance for the configuration; work_dir holds its .ini and the stats
// it writes. InputError naming dram.model when rtsim was built without DRAMsim3.
std::unique_ptr<DramReference> make_dramsim3(const DramConfig& config, uint32_t access_bytes,
                                             const std::string& work_dir);

}  // namespace rtsim::sim
