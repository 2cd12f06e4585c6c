#include "core/bytes.h"

#include "raycloth/error.h"

namespace raycloth {

void ByteReader::fail(const std::string& reason) const { throw InputError(file_, "", reason); }
void ByteReader::fail_truncated() const { fail("is truncated or damaged; start the run again without --resume"); }

}  // namespace raycloth
