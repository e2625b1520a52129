#include "server/service.h"

namespace km::server {

Service::Service(std::unique_ptr<Storage> storage, ServiceOptions options)
    : storage_(std::move(storage)),
      tolerances_(*storage_),
      instruments_(*storage_),
      measurements_(*storage_, UploadOptions{options.max_upload_bytes, options.upload_limits}),
      models_(*storage_),
      access_(*storage_),
      streams_(std::make_unique<StreamService>(*storage_, measurements_)),
      servo_(*storage_, measurements_, models_, *streams_),
      studies_(std::make_unique<StudyService>(
          *storage_, *storage_, measurements_, models_,
          StudyOptions{options.max_calibration_tests, options.max_calibration_samples,
                       options.jobs})),
      reports_(*this, measurements_, *studies_, *storage_),
      audits_(std::make_unique<AuditScheduler>(*this, options.audits)) {
  // Every answer about a measurement carries its conformance with the newest tolerances.
  measurements_.SetConformanceJudges(tolerances_.Judges());
  // Every upload naming a registered instrument takes the register's uncertainties.
  measurements_.SetInstrumentHook(instruments_.Hook());
}

Service::~Service() {
  // The scheduler first (it reads through this class), then the job workers, then the streams.
  audits_.reset();
  studies_.reset();
  streams_.reset();
}

}  // namespace km::server
