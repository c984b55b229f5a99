// libFuzzer harness: the Crazyflie readers (adapters/crazyflie_csv.hpp), both on every input
// (through a scratch file). Accepted data has one value per row in every column.
#include <cstddef>
#include <cstdint>

#include "dronetwin/adapters/crazyflie_csv.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dronetwin;
  static fuzz::ScratchFile file("crazyflie.csv");
  const std::string& path = file.write(data, size);
  ThrustStandData stand;
  if (fuzz::accepted([&] { stand = read_thrust_stand_csv(path); })) {
    fuzz::check(stand.rows() > 0 && stand.weight_g.size() == stand.rows() &&
                    stand.vbat_V.size() == stand.rows() && stand.rpm[3].size() == stand.rows() &&
                    stand.power_W.size() == stand.rows(),
                "thrust-stand columns of different lengths");
  }
  CrazyPadFlight flight;
  if (fuzz::accepted([&] { flight = read_crazypad_csv(path); })) {
    fuzz::check(flight.rows() >= 2 && flight.pwm[3].size() == flight.rows() &&
                    flight.acc_g[2].size() == flight.rows() &&
                    flight.yaw_deg.size() == flight.rows(),
                "CrazyPAD columns of different lengths");
    for (std::size_t r = 1; r < flight.rows(); ++r) {
      fuzz::check(flight.t_s[r] > flight.t_s[r - 1], "CrazyPAD time does not increase");
    }
  }
  return 0;
}
