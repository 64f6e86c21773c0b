// sinew-run's -j reaches ITK (app/common/thread_limits.h): its global default number of threads,
// which its readers and the registration's filters take, is the limit once set, in a process that
// has not used ITK yet (this one: nothing before the first test function touches it).
#include "thread_limits.h"

#include <QtTest>

#include <itkMultiThreaderBase.h>

#include <thread>

using namespace sinew;

class TestThreadLimits : public QObject {
  Q_OBJECT

private slots:
  void itkTakesTheLimit() {
    // A limit that is neither ITK's default here (the cores) nor 1, so that it shows.
    const int limit = int(std::max(2u, std::thread::hardware_concurrency())) + 1;
    limitLibraryThreads(limit);
    QCOMPARE(int(itk::MultiThreaderBase::GetGlobalDefaultNumberOfThreads()), limit);
  }
};

QTEST_APPLESS_MAIN(TestThreadLimits)
#include "tst_thread_limits.moc"
